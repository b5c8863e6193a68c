/// @file evaluation_report.cpp
/// Text report, JSON and CSV outputs of a TrajectoryEvaluation.

#include "planetary_vo/eval/evaluation_report.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

namespace planetary_vo {

namespace {

std::string format(const char* fmt, double a) {
  char text[64];
  std::snprintf(text, sizeof(text), fmt, a);
  return text;
}

/// "rmse 1.234 mean 1.000 median 0.900 max 3.000 <unit>"
std::string statsLine(const ErrorStatistics& s, const std::string& unit, const char* fmt = "%.4f") {
  return "rmse " + format(fmt, s.rmse) + "  mean " + format(fmt, s.mean) + "  median " +
         format(fmt, s.median) + "  std " + format(fmt, s.std_dev) + "  min " + format(fmt, s.min) +
         "  max " + format(fmt, s.max) + " " + unit;
}

// ---------------------------------------------------------------------------------------------------------------
// A minimal JSON writer: objects, arrays, numbers (non-finite as null) and escaped strings.
// ---------------------------------------------------------------------------------------------------------------
class Json {
 public:
  std::string str() const { return out_.str(); }

  Json& beginObject(const std::string& key = "") { return open(key, '{'); }
  Json& endObject() { return close('}'); }
  Json& beginArray(const std::string& key = "") { return open(key, '['); }
  Json& endArray() { return close(']'); }
  Json& number(const std::string& key, double value) {
    prefix(key);
    if (std::isfinite(value)) {
      char text[32];
      std::snprintf(text, sizeof(text), "%.10g", value);
      out_ << text;
    } else {
      out_ << "null";
    }
    return *this;
  }
  Json& integer(const std::string& key, long long value) {
    prefix(key);
    out_ << value;
    return *this;
  }
  Json& string(const std::string& key, const std::string& value) {
    prefix(key);
    quoted(value);
    return *this;
  }
  Json& vector(const std::string& key, const Eigen::Vector3d& v) {  // on one line: [x, y, z]
    prefix(key);
    char text[96];
    std::snprintf(text, sizeof(text), "[%.10g, %.10g, %.10g]", v.x(), v.y(), v.z());
    out_ << (v.allFinite() ? text : "[null, null, null]");
    return *this;
  }
  Json& stats(const std::string& key, const ErrorStatistics& s) {
    if (s.count == 0) {  // no value: every statistic null, not 0
      const double none = std::numeric_limits<double>::quiet_NaN();
      return statsObject(key, ErrorStatistics{0, none, none, none, none, none, none, none});
    }
    return statsObject(key, s);
  }
  Json& statsObject(const std::string& key, const ErrorStatistics& s) {
    beginObject(key);
    integer("count", static_cast<long long>(s.count));
    number("rmse", s.rmse).number("mean", s.mean).number("median", s.median).number("std", s.std_dev);
    number("min", s.min).number("max", s.max).number("max_abs", s.max_abs);
    return endObject();
  }
  Json& nees(const std::string& key, const NeesStatistics& s) {
    beginObject(key);
    integer("dof", s.dof).integer("count", static_cast<long long>(s.count));
    number("mean", s.mean).number("median", s.median).number("max", s.max);
    number("mean_lower_95", s.mean_lower_95).number("mean_upper_95", s.mean_upper_95);
    number("pose_lower_95", s.pose_lower_95).number("pose_upper_95", s.pose_upper_95);
    number("fraction_inside_95", s.fraction_inside_95).string("verdict", s.verdict());
    return endObject();
  }
  Json& boolean(const std::string& key, bool value) {
    prefix(key);
    out_ << (value ? "true" : "false");
    return *this;
  }
  Json& numbers(const std::string& key, const std::vector<double>& values) {  // on one line
    prefix(key);
    out_ << '[';
    char text[32];
    for (size_t k = 0; k < values.size(); ++k) {
      if (std::isfinite(values[k]))
        std::snprintf(text, sizeof(text), "%.10g", values[k]);
      else
        std::snprintf(text, sizeof(text), "null");
      out_ << (k ? ", " : "") << text;
    }
    out_ << ']';
    return *this;
  }

 private:
  Json& open(const std::string& key, char bracket) {
    prefix(key);
    out_ << bracket;
    first_.push_back(true);
    return *this;
  }
  Json& close(char bracket) {
    first_.pop_back();
    out_ << '\n' << std::string(2 * first_.size(), ' ') << bracket;
    return *this;
  }
  void prefix(const std::string& key) {
    if (!first_.empty()) {
      if (!first_.back()) out_ << ',';
      first_.back() = false;
      out_ << '\n' << std::string(2 * first_.size(), ' ');
    }
    if (!key.empty()) {
      quoted(key);
      out_ << ": ";
    }
  }
  void quoted(const std::string& s) {
    out_ << '"';
    for (unsigned char c : s) {
      if (c == '"' || c == '\\') {
        out_ << '\\' << c;
      } else if (c == '\n') {
        out_ << "\\n";
      } else if (c < 0x20) {
        char esc[8];
        std::snprintf(esc, sizeof(esc), "\\u%04x", c);
        out_ << esc;
      } else {
        out_ << c;
      }
    }
    out_ << '"';
  }
  std::ostringstream out_;
  std::vector<bool> first_;
};

/// One value of every pose.
template <typename Getter>
std::vector<double> series(const TrajectoryEvaluation& ev, Getter get) {
  std::vector<double> values;
  values.reserve(ev.poses.size());
  for (const PoseError& p : ev.poses) values.push_back(get(p));
  return values;
}

std::string vectorText(const Eigen::Vector3d& v, const char* fmt = "%.3f") {
  const Eigen::Vector3d u = v + Eigen::Vector3d::Zero();  // -0 + 0 = +0: no "-0" in the text
  return "[" + format(fmt, u.x()) + ", " + format(fmt, u.y()) + ", " + format(fmt, u.z()) + "]";
}

std::string neesLine(const NeesStatistics& s) {
  if (s.count == 0) return "no pose with a covariance within the association tolerance";
  return "mean " + format("%.3f", s.mean) + " (" + std::to_string(s.dof) + " dof, 95 % bounds of the mean " +
         format("%.3f", s.mean_lower_95) + " .. " + format("%.3f", s.mean_upper_95) + "): " + s.verdict() +
         "; median " + format("%.3f", s.median) + ", max " + format("%.3f", s.max) + "; " +
         format("%.1f", 100.0 * s.fraction_inside_95) + " % of " + std::to_string(s.count) +
         " poses within " + format("%.3f", s.pose_lower_95) + " .. " + format("%.3f", s.pose_upper_95);
}

}  // namespace

std::string formatReport(const TrajectoryEvaluation& ev) {
  std::ostringstream r;
  r << "Trajectory evaluation\n";
  r << "  poses: ground truth " << ev.num_ground_truth << ", estimate " << ev.num_estimate << ", associated "
    << ev.num_associated << " (max dt " << format("%.4f", ev.options.max_dt_s) << " s)\n";
  r << "  duration " << format("%.3f", ev.duration_s) << " s, ground-truth path length "
    << format("%.3f", ev.gt_path_length_m) << " m\n";
  r << "  alignment: " << toString(ev.options.alignment);
  if (ev.options.align_num_pairs > 0) r << " on the first " << ev.options.align_num_pairs << " poses";
  if (ev.options.alignment == AlignmentMode::kFirstPose) {
    const FirstPoseHandover& h = ev.options.first_pose;
    r << " (state handed over at the first pose";
    if (h.scale_window_s > 0.0)
      r << "; scale " << format("%.6f", ev.first_pose_window_scale) << " from the first "
        << format("%.3f", h.scale_window_s) << " s";
    if (!h.position_error_m.isZero(0.0)) r << "; position error " << vectorText(h.position_error_m) << " m";
    if (!h.attitude_error_deg.isZero(0.0))
      r << "; attitude error " << vectorText(h.attitude_error_deg, "%.4f") << " deg";
    if (h.scale_error != 0.0) r << "; scale error " << format("%+.4f", 100.0 * h.scale_error) << " %";
    r << ")";
  }
  const Eigen::AngleAxisd aa(ev.alignment.R_gt_est);
  r << ", scale " << format("%.6f", ev.alignment.scale) << ", rotation "
    << format("%.3f", aa.angle() * 180.0 / M_PI) << " deg, translation ["
    << format("%.3f", ev.alignment.t_gt_est_m.x()) << ", " << format("%.3f", ev.alignment.t_gt_est_m.y())
    << ", " << format("%.3f", ev.alignment.t_gt_est_m.z()) << "] m\n";
  r << "\nAbsolute trajectory error (after alignment)\n";
  r << "  translation  " << statsLine(ev.ate_m, "m") << "\n";
  r << "  translation  rmse " << format("%.4f", ev.ate_rmse_percent) << " % of the path length\n";
  r << "  rotation     " << statsLine(ev.rotation_deg, "deg") << "\n";
  r << "  attitude change since the first pose (independent of the alignment)\n";
  r << "  rotation     " << statsLine(ev.attitude_drift_deg, "deg") << "\n";
  r << "  final position error " << format("%.4f", ev.final_position_error_m) << " m\n";
  r << "\nPosition error per world axis, estimate - ground truth (landing-site frame: x crossrange, y "
       "downrange, "
       "z altitude)\n";
  r << "  crossrange x " << statsLine(ev.crossrange_error_m, "m") << "\n";
  r << "  downrange  y " << statsLine(ev.downrange_error_m, "m") << "\n";
  r << "  altitude   z " << statsLine(ev.altitude_error_m, "m") << "\n";

  const FinalErrors& f = ev.final_errors;
  r << "\nNavigation errors\n";
  r << "  final (last associated pose, t " << format("%.3f", f.timestamp_s) << " s, "
    << format("%.3f", f.time_since_start_s) << " s after the first; distance travelled "
    << format("%.3f", ev.distance_travelled_m) << " m)\n";
  r << "    position " << format("%.4f", f.position_error_m)
    << " m (" + format("%.4f", f.position_error_percent_of_distance) + " % of the distance), error "
    << vectorText(f.position_error_world_m, "%.4f") << " m\n";
  r << "    velocity " << format("%.4f", f.velocity_error_mps) << " m/s, error "
    << vectorText(f.velocity_error_world_mps, "%.4f") << " m/s\n";
  r << "    attitude " << format("%.4f", f.attitude_error_deg) << " deg, tilt "
    << format("%.4f", f.tilt_error_deg) << " deg, scale error " << format("%.4f", f.scale_error_percent)
    << " %\n";
  r << "  velocity " << statsLine(ev.velocity_error_mps, "m/s") << " (" << ev.velocity_error_mps.count
    << " poses; truth: " << ev.velocity_truth_source << ", estimate: " << ev.velocity_estimate_source
    << ")\n";
  r << "  tilt     " << statsLine(ev.tilt_error_deg, "deg") << " (up "
    << vectorText(ev.options.up_world, "%.0f") << ")\n";
  r << "  scale    " << statsLine(ev.scale_error_percent, "%") << ", max |.| "
    << format("%.4f", ev.scale_error_percent.max_abs) << " % (" << ev.scale_error_percent.count
    << " poses; trailing window " << format("%.3f", ev.options.scale_window_s) << " s)\n";
  if (ev.covariance_dimension > 0 || ev.has_velocity_covariance) {
    r << "\nNEES (estimated covariance";
    if (ev.covariance_dimension > 0) r << " " << ev.covariance_dimension << "x" << ev.covariance_dimension;
    if (ev.has_velocity_covariance) r << (ev.covariance_dimension > 0 ? "; " : " ") << "velocity 3x3";
    r << ")\n";
    if (ev.covariance_dimension > 0) r << "  position " << neesLine(ev.nees_position) << "\n";
    if (ev.covariance_dimension == 6) {
      r << "  attitude " << neesLine(ev.nees_attitude) << "\n";
      r << "  pose     " << neesLine(ev.nees_pose) << "\n";
    }
    if (ev.has_velocity_covariance) r << "  velocity " << neesLine(ev.nees_velocity) << "\n";
  }

  r << "\nRelative pose error\n";
  for (const RelativeError& e : ev.rpe) {
    r << "  delta " << (e.delta_unit == "frames" ? format("%.0f", e.delta) : format("%.3f", e.delta)) << " "
      << e.delta_unit;
    if (std::isfinite(e.path_fraction))
      r << " = " << format("%.0f", 100.0 * e.path_fraction) << " % of the path";
    r << " (" << e.num_pairs << " pairs)\n";
    r << "    translation " << statsLine(e.translation_m, "m") << "\n";
    if (e.translation_percent.count > 0)
      r << "    translation " << statsLine(e.translation_percent, "%") << "\n";
    r << "    rotation    " << statsLine(e.rotation_deg, "deg") << "\n";
    if (e.rotation_deg_per_m.count > 0)
      r << "    rotation    " << statsLine(e.rotation_deg_per_m, "deg/m", "%.5f") << "\n";
  }
  return r.str();
}

std::string toJson(const TrajectoryEvaluation& ev, bool with_poses) {
  Json j;
  j.beginObject();
  j.integer("num_ground_truth", static_cast<long long>(ev.num_ground_truth));
  j.integer("num_estimate", static_cast<long long>(ev.num_estimate));
  j.integer("num_associated", static_cast<long long>(ev.num_associated));
  j.number("max_dt_s", ev.options.max_dt_s);
  j.number("duration_s", ev.duration_s);
  j.number("gt_path_length_m", ev.gt_path_length_m);
  j.number("distance_travelled_m", ev.distance_travelled_m);
  j.beginObject("alignment");
  j.string("mode", toString(ev.options.alignment));
  j.integer("num_pairs_used", static_cast<long long>(ev.options.align_num_pairs));
  j.number("scale", ev.alignment.scale);
  j.beginArray("R_gt_est");
  for (int r = 0; r < 3; ++r) j.vector("", ev.alignment.R_gt_est.row(r).transpose());
  j.endArray();
  j.vector("t_gt_est_m", ev.alignment.t_gt_est_m);
  if (ev.options.alignment == AlignmentMode::kFirstPose) {
    const FirstPoseHandover& h = ev.options.first_pose;
    j.beginObject("first_pose");
    j.number("scale_window_s", h.scale_window_s).number("window_scale", ev.first_pose_window_scale);
    j.vector("initial_position_error_m", h.position_error_m);
    j.vector("initial_attitude_error_deg", h.attitude_error_deg);
    j.number("initial_scale_error", h.scale_error);
    j.endObject();
  }
  j.endObject();
  j.stats("ate_m", ev.ate_m);
  j.number("ate_rmse_percent_of_path", ev.ate_rmse_percent);
  j.stats("rotation_error_deg", ev.rotation_deg);
  j.stats("attitude_drift_deg", ev.attitude_drift_deg);
  j.number("final_position_error_m", ev.final_position_error_m);
  j.stats("crossrange_error_m", ev.crossrange_error_m);
  j.stats("downrange_error_m", ev.downrange_error_m);
  j.stats("altitude_error_m", ev.altitude_error_m);
  const FinalErrors& f = ev.final_errors;
  j.beginObject("final");
  j.number("t_s", f.timestamp_s).number("t_rel_s", f.time_since_start_s);
  j.number("position_error_m", f.position_error_m);
  j.number("position_error_percent_of_distance", f.position_error_percent_of_distance);
  j.vector("position_error_world_m", f.position_error_world_m);
  j.number("velocity_error_mps", f.velocity_error_mps);
  j.vector("velocity_error_world_mps", f.velocity_error_world_mps);
  j.number("attitude_error_deg", f.attitude_error_deg).number("tilt_error_deg", f.tilt_error_deg);
  j.number("scale_error_percent", f.scale_error_percent);
  j.endObject();
  j.stats("velocity_error_mps", ev.velocity_error_mps);
  j.string("velocity_truth_source", ev.velocity_truth_source);
  j.string("velocity_estimate_source", ev.velocity_estimate_source);
  j.number("gap_factor", ev.options.gap_factor);
  j.stats("tilt_error_deg", ev.tilt_error_deg);
  j.vector("up_axis_world", ev.options.up_world);
  j.stats("scale_error_percent", ev.scale_error_percent);
  j.number("scale_window_s", ev.options.scale_window_s);
  if (ev.covariance_dimension > 0 || ev.has_velocity_covariance) {
    j.beginObject("nees");
    j.integer("covariance_dimension", ev.covariance_dimension);
    if (ev.covariance_dimension > 0) j.nees("position", ev.nees_position);
    if (ev.covariance_dimension == 6) j.nees("attitude", ev.nees_attitude).nees("pose", ev.nees_pose);
    if (ev.has_velocity_covariance) j.nees("velocity", ev.nees_velocity);
    j.endObject();
  }
  j.beginArray("rpe");
  for (const RelativeError& e : ev.rpe) {
    j.beginObject();
    j.string("delta_unit", e.delta_unit).number("delta", e.delta).number("path_fraction", e.path_fraction);
    j.integer("num_pairs", static_cast<long long>(e.num_pairs));
    j.stats("translation_m", e.translation_m).stats("translation_percent", e.translation_percent);
    j.stats("rotation_deg", e.rotation_deg).stats("rotation_deg_per_m", e.rotation_deg_per_m);
    j.endObject();
  }
  j.endArray();
  if (with_poses) {
    j.beginObject("series");
    j.numbers("t_s", series(ev, [](const PoseError& p) { return p.timestamp_s; }));
    j.numbers("t_rel_s", series(ev, [](const PoseError& p) { return p.time_since_start_s; }));
    j.numbers("distance_travelled_m", series(ev, [](const PoseError& p) { return p.distance_travelled_m; }));
    j.numbers("position_error_m", series(ev, [](const PoseError& p) { return p.translation_error_m; }));
    j.numbers("position_error_percent_of_distance",
              series(ev, [](const PoseError& p) { return p.position_error_percent_of_distance; }));
    j.numbers("crossrange_error_m", series(ev, [](const PoseError& p) { return p.position_error_m.x(); }));
    j.numbers("downrange_error_m", series(ev, [](const PoseError& p) { return p.position_error_m.y(); }));
    j.numbers("altitude_error_m", series(ev, [](const PoseError& p) { return p.position_error_m.z(); }));
    j.numbers("velocity_error_mps", series(ev, [](const PoseError& p) { return p.velocity_error_norm_mps; }));
    j.numbers("velocity_error_x_mps",
              series(ev, [](const PoseError& p) { return p.velocity_error_mps.x(); }));
    j.numbers("velocity_error_y_mps",
              series(ev, [](const PoseError& p) { return p.velocity_error_mps.y(); }));
    j.numbers("velocity_error_z_mps",
              series(ev, [](const PoseError& p) { return p.velocity_error_mps.z(); }));
    j.numbers("attitude_error_deg", series(ev, [](const PoseError& p) { return p.rotation_error_deg; }));
    j.numbers("tilt_error_deg", series(ev, [](const PoseError& p) { return p.tilt_error_deg; }));
    j.numbers("scale_error_percent", series(ev, [](const PoseError& p) { return p.scale_error_percent; }));
    if (ev.covariance_dimension > 0)
      j.numbers("nees_position", series(ev, [](const PoseError& p) { return p.nees_position; }));
    if (ev.covariance_dimension == 6) {
      j.numbers("nees_attitude", series(ev, [](const PoseError& p) { return p.nees_attitude; }));
      j.numbers("nees_pose", series(ev, [](const PoseError& p) { return p.nees_pose; }));
    }
    if (ev.has_velocity_covariance)
      j.numbers("nees_velocity", series(ev, [](const PoseError& p) { return p.nees_velocity; }));
    j.endObject();
    j.beginArray("poses");
    for (const PoseError& p : ev.poses) {
      j.beginObject();
      j.number("t_s", p.timestamp_s);
      j.vector("gt_position_m", p.position_gt_m).vector("est_position_m", p.position_est_m);
      j.vector("error_m", p.position_error_m);
      j.number("ate_m", p.translation_error_m).number("rotation_error_deg", p.rotation_error_deg);
      j.endObject();
    }
    j.endArray();
  }
  j.endObject();
  return j.str() + "\n";
}

void writeJson(const std::string& path, const TrajectoryEvaluation& ev, bool with_poses) {
  std::ofstream out(path);
  if (!out || !(out << toJson(ev, with_poses)) || !out.flush()) throw EvalError("cannot write " + path);
}

void writePoseErrorsCsv(const std::string& path, const TrajectoryEvaluation& ev) {
  std::ofstream out(path);
  if (!out) throw EvalError("cannot write " + path);
  out << "t_s,gt_x_m,gt_y_m,gt_z_m,est_x_m,est_y_m,est_z_m,err_x_m,err_y_m,err_z_m,ate_m,rot_err_deg,"
         "gt_qx,gt_qy,gt_qz,gt_qw,est_qx,est_qy,est_qz,est_qw,"
         "t_rel_s,dist_m,gt_vx_mps,gt_vy_mps,gt_vz_mps,est_vx_mps,est_vy_mps,est_vz_mps,vel_err_x_mps,"
         "vel_err_y_mps,vel_err_z_mps,vel_err_mps,tilt_err_deg,scale_err_pct,nees_pos,nees_att,nees_pose,nees_vel\n";
  std::string line;
  const auto add = [&line](const char* fmt, double value) {
    if (!line.empty()) line += ',';
    line += std::isfinite(value) ? format(fmt, value) : "nan";
  };
  for (const PoseError& p : ev.poses) {
    line.clear();
    add("%.9f", p.timestamp_s);
    for (const Eigen::Vector3d* v : {&p.position_gt_m, &p.position_est_m, &p.position_error_m})
      for (int i = 0; i < 3; ++i) add("%.6f", (*v)[i]);
    add("%.6f", p.translation_error_m);
    add("%.6f", p.rotation_error_deg);
    for (const Eigen::Quaterniond* q : {&p.q_world_cam_gt, &p.q_world_cam_est})
      for (double c : {q->x(), q->y(), q->z(), q->w()}) add("%.9f", c);
    add("%.9f", p.time_since_start_s);
    add("%.6f", p.distance_travelled_m);
    for (const Eigen::Vector3d* v : {&p.velocity_gt_mps, &p.velocity_est_mps, &p.velocity_error_mps})
      for (int i = 0; i < 3; ++i) add("%.6f", (*v)[i]);
    add("%.6f", p.velocity_error_norm_mps);
    add("%.6f", p.tilt_error_deg);
    add("%.6f", p.scale_error_percent);
    add("%.6g", p.nees_position);
    add("%.6g", p.nees_attitude);
    add("%.6g", p.nees_pose);
    add("%.6g", p.nees_velocity);
    out << line << '\n';
  }
  if (!out.flush()) throw EvalError("error while writing " + path);
}

}  // namespace planetary_vo
