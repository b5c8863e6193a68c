/// @file evaluation_report.cpp
/// Text report, JSON and CSV outputs of a TrajectoryEvaluation.

#include "planetary_vo/eval/evaluation_report.h"

#include <cmath>
#include <cstdio>
#include <fstream>
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
    beginObject(key);
    integer("count", static_cast<long long>(s.count));
    number("rmse", s.rmse).number("mean", s.mean).number("median", s.median).number("std", s.std_dev);
    number("min", s.min).number("max", s.max);
    return endObject();
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
  r << "\nRelative pose error\n";
  for (const RelativeError& e : ev.rpe) {
    r << "  delta " << (e.delta_unit == "frames" ? format("%.0f", e.delta) : format("%.3f", e.delta)) << " "
      << e.delta_unit << " (" << e.num_pairs << " pairs)\n";
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
  j.beginObject("alignment");
  j.string("mode", toString(ev.options.alignment));
  j.integer("num_pairs_used", static_cast<long long>(ev.options.align_num_pairs));
  j.number("scale", ev.alignment.scale);
  j.beginArray("R_gt_est");
  for (int r = 0; r < 3; ++r) j.vector("", ev.alignment.R_gt_est.row(r).transpose());
  j.endArray();
  j.vector("t_gt_est_m", ev.alignment.t_gt_est_m);
  j.endObject();
  j.stats("ate_m", ev.ate_m);
  j.number("ate_rmse_percent_of_path", ev.ate_rmse_percent);
  j.stats("rotation_error_deg", ev.rotation_deg);
  j.stats("attitude_drift_deg", ev.attitude_drift_deg);
  j.number("final_position_error_m", ev.final_position_error_m);
  j.stats("crossrange_error_m", ev.crossrange_error_m);
  j.stats("downrange_error_m", ev.downrange_error_m);
  j.stats("altitude_error_m", ev.altitude_error_m);
  j.beginArray("rpe");
  for (const RelativeError& e : ev.rpe) {
    j.beginObject();
    j.string("delta_unit", e.delta_unit).number("delta", e.delta);
    j.integer("num_pairs", static_cast<long long>(e.num_pairs));
    j.stats("translation_m", e.translation_m).stats("translation_percent", e.translation_percent);
    j.stats("rotation_deg", e.rotation_deg).stats("rotation_deg_per_m", e.rotation_deg_per_m);
    j.endObject();
  }
  j.endArray();
  if (with_poses) {
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
         "gt_qx,gt_qy,gt_qz,gt_qw,est_qx,est_qy,est_qz,est_qw\n";
  char line[512];
  for (const PoseError& p : ev.poses) {
    const Eigen::Quaterniond& g = p.q_world_cam_gt;
    const Eigen::Quaterniond& e = p.q_world_cam_est;
    std::snprintf(line, sizeof(line),
                  "%.9f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,"
                  "%.9f,%.9f\n",
                  p.timestamp_s, p.position_gt_m.x(), p.position_gt_m.y(), p.position_gt_m.z(),
                  p.position_est_m.x(), p.position_est_m.y(), p.position_est_m.z(), p.position_error_m.x(),
                  p.position_error_m.y(), p.position_error_m.z(), p.translation_error_m, p.rotation_error_deg,
                  g.x(), g.y(), g.z(), g.w(), e.x(), e.y(), e.z(), e.w());
    out << line;
  }
  if (!out.flush()) throw EvalError("error while writing " + path);
}

}  // namespace planetary_vo
