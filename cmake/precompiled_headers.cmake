# Precompiled headers: the third-party headers most translation units parse
# (the standard library, Eigen, Ceres' Jet, nlohmann/json; CLI11 in the
# commands, GoogleTest in the tests) are parsed once per build instead of
# once per file. Builds dominate CI: measured, these headers cost 1-6 s of a
# translation unit's compile each (CLI11 alone 5.7 s).
#
# Each kind of PCH is compiled once, in a target of its own that links what
# its users link, and reused (REUSE_FROM) by every target of that kind: GCC
# uses a PCH only when the macros it was built with match (-Winvalid-pch
# warns when one is ignored), so the kinds follow the libraries' compile
# definitions (Ceres brings glog's, GoogleTest its own).
#   kcrig_use_pch(TARGET core|library|cli|test)
option(KCRIG_PRECOMPILED_HEADERS "Precompile the common third-party headers"
       ON)

set(KCRIG_PCH_CORE
    <algorithm> <array> <atomic> <chrono> <cmath> <cstdint> <cstdio>
    <filesystem> <fstream> <functional> <limits> <map> <memory> <optional>
    <random> <sstream> <string> <thread> <utility> <vector>
    <Eigen/Core> <Eigen/Dense> <nlohmann/json.hpp>)

function(kcrig_add_pch kind)
  add_library(kcrig_pch_${kind} OBJECT ${PROJECT_SOURCE_DIR}/cmake/pch.cc)
  target_link_libraries(kcrig_pch_${kind} PRIVATE ${ARGN})
  target_precompile_headers(kcrig_pch_${kind} PRIVATE ${KCRIG_PCH_CORE}
                            ${KCRIG_PCH_${kind}})
endfunction()

if(KCRIG_PRECOMPILED_HEADERS)
  set(KCRIG_PCH_library <ceres/jet.h>)
  set(KCRIG_PCH_cli <ceres/jet.h> <CLI/CLI.hpp>)
  set(KCRIG_PCH_test <ceres/jet.h> <gtest/gtest.h>)
  set(common Eigen3::Eigen nlohmann_json::nlohmann_json)
  kcrig_add_pch(core ${common})
  kcrig_add_pch(library ${common} Ceres::ceres)
  kcrig_add_pch(cli ${common} Ceres::ceres CLI11::CLI11)
  find_package(GTest QUIET)
  if(GTest_FOUND)
    kcrig_add_pch(test ${common} Ceres::ceres GTest::gtest)
  endif()
endif()

function(kcrig_use_pch target kind)
  if(TARGET kcrig_pch_${kind})
    target_precompile_headers(${target} REUSE_FROM kcrig_pch_${kind})
  endif()
endfunction()
