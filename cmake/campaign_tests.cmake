# Tests of the Monte Carlo campaign tool (scripts/vo_campaign.py, docs/campaigns.md), included by the top
# CMakeLists.txt inside if(CATKIN_ENABLE_TESTING). Python unittest files run by the system python (numpy and
# matplotlib from Debian); the end-to-end ones run the real lunar_render, vo_run and vo_eval of this build.
#
#   campaign_statistics  no tools: dispersion draws, run classification, statistics and gathering on synthetic
#                        result files with known mean / std / p99 / max, resampling on the common time grid,
#                        a missing result counted as a failure
#   campaign_local       a 3-run, 2-configuration campaign of approach_down at 96 px, 3 s on the local
#                        process pool: plan, one render per run (counted by shims around the tools), results,
#                        summary.json against the result files, plots, --write-docs, --gather, a second
#                        execution served by the render cache, the replay of one run reproducing it exactly
#   campaign_slurm       the same campaign through a private single-node Slurm (munged + slurmctld + slurmd
#                        started by scripts/slurm_local.sh in a folder of its own, stopped even on failure):
#                        every array task its own Slurm job (task logs, jobcomp records, the results' Slurm
#                        ids), results identical to the local run. Needs root and the Debian packages munge,
#                        slurmctld, slurmd, slurm-client (scripts/install_deps.sh)

set(CAMPAIGN_TEST_DIR ${PROJECT_SOURCE_DIR}/test/campaign)
set(CAMPAIGN_TEST_OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/test_output)

add_test(NAME campaign_statistics
         COMMAND /usr/bin/python3 ${CAMPAIGN_TEST_DIR}/test_campaign_statistics.py)

foreach(kind local slurm)
  add_test(NAME campaign_${kind}
           COMMAND ${CMAKE_COMMAND} -E env PLANETARY_VO_BIN=$<TARGET_FILE_DIR:vo_run>
                   PLANETARY_VO_DATA=${PLANETARY_VO_DATA_DIR}
                   CAMPAIGN_TEST_OUTPUT=${CAMPAIGN_TEST_OUTPUT}/campaign_${kind}
                   /usr/bin/python3 ${CAMPAIGN_TEST_DIR}/test_campaign_${kind}.py)
endforeach()
# Each test file stops itself well before this (its campaigns have their own time limits), so that the Slurm
# test always reaches its clean-up; ctest's limit is the backstop.
set_tests_properties(campaign_statistics campaign_local campaign_slurm PROPERTIES TIMEOUT 300)

# photoclinometry_check: scripts/photoclinometry_check.py on a synthetic one-run campaign (swells the map sees
# halved, Lambertian nadir images): the corrected slope comes closer to the truth, worse with the Sun's azimuth
# flipped; the truth is moved by the run's navigation error; a map made with the shading tilt on is refused
add_test(NAME photoclinometry_check
         COMMAND /usr/bin/python3 ${CAMPAIGN_TEST_DIR}/test_photoclinometry_check.py)
set_tests_properties(photoclinometry_check PROPERTIES TIMEOUT 120)

# `cmake --build build --target tests` builds the tools the end-to-end tests run.
add_dependencies(tests lunar_render vo_run vo_eval terrain_eval)

# A Python test of a tool script on the VO rostests' descent (the real tools of this build); OUTPUT_VAR names
# the environment variable that gives it its output folder.
function(add_descent_tool_test name script output_var timeout_s)
  add_test(NAME ${name}
           COMMAND ${CMAKE_COMMAND} -E env PLANETARY_VO_BIN=$<TARGET_FILE_DIR:vo_run>
                   PLANETARY_VO_TEST_DATASET=${VO_TEST_DATASET}
                   ${output_var}=${CAMPAIGN_TEST_OUTPUT}/${name}
                   /usr/bin/python3 ${CAMPAIGN_TEST_DIR}/${script})
  set_tests_properties(${name} PROPERTIES TIMEOUT ${timeout_s})
endfunction()

# The sensitivity sweep (scripts/vo_sensitivity.py, docs/visual_core.md) on the VO rostests' short descent:
#   sensitivity_tool     two parameters x four values with the real vo_run and vo_eval: one run per distinct
#                        configuration, the tables (base value, worst ratio, cliff), the plots, a second
#                        invocation reusing every run, unknown parameters and missing datasets refused; the
#                        --campaigns mode: the median over dispersed renders and a lost render as a cliff (on
#                        made-up results), and a run over a campaign-shaped folder of two renders; the --starts
#                        mode: three starts per setting (each from its own input image), their median the figure
if(VO_TEST_DATASET)
  add_descent_tool_test(sensitivity_tool test_sensitivity_tool.py SENSITIVITY_TEST_OUTPUT 600)
  # benchmark_starts: scripts/vo_benchmark.py --starts (score_starts: the row run again from later images, each
  # start scored; the median over the starts with a lost one counted as worst)
  add_descent_tool_test(benchmark_starts test_benchmark_starts.py BENCHMARK_STARTS_TEST_OUTPUT 300)
  # terrain_errors_tool: scripts/terrain_errors.py (docs/terrain/README.md) on the descent's true terrain taken
  # as the estimate: its slope RMSE and precision/recall equal terrain_eval's at the map's resolution, and its
  # white-noise table falls with the noise; its shading-relief report separates perfectly with the true roughness as
  # the layer
  add_descent_tool_test(terrain_errors_tool test_terrain_errors.py TERRAIN_ERRORS_TEST_OUTPUT 300)
endif()
# hazard_campaign_renders_from: scripts/hazard_campaign.py, a one-run campaign at 256 px (the last 5 s of an
# approach) and the same draw mapped again with --renders-from: the run folder links the dataset it used, the
# trajectory repeats exactly, a second time works with the link there, another draw's renders are refused
add_descent_tool_test(hazard_campaign_renders_from test_hazard_campaign.py HAZARD_CAMPAIGN_TEST_OUTPUT 300)
