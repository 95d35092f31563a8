# ctest install_consumer: cmake --install the build into a fresh prefix, then configure, build and run
# examples/ against that prefix alone (a C++ user's find_package(pgi CONFIG REQUIRED)).
# Usage: cmake -DSOURCE=... -DBUILD=... -DWORK=... -P consumer.cmake
file(REMOVE_RECURSE ${WORK})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()
run(${CMAKE_COMMAND} --install ${BUILD} --prefix ${WORK}/prefix)
foreach(f include/pgi/pgi.hpp include/pgi/scheme/scheme.hpp include/pgi/poisson/newton_step.hpp
          include/pgi/series/poly.hpp lib/cmake/pgi/pgiConfig.cmake lib/cmake/pgi/pgiConfigVersion.cmake)
  if(NOT EXISTS ${WORK}/prefix/${f})
    message(FATAL_ERROR "not installed: ${f}")
  endif()
endforeach()
# Each layer's detail/ (its internals) is not installed, and every installed header compiles against the prefix
# alone (one unit includes them all as a consumer would): no public header includes an internal one.
foreach(dir series poisson magnus scheme)
  if(EXISTS ${WORK}/prefix/include/pgi/${dir}/detail)
    message(FATAL_ERROR "installed: include/pgi/${dir}/detail")
  endif()
endforeach()
file(GLOB_RECURSE installed RELATIVE ${WORK}/prefix/include ${WORK}/prefix/include/pgi/*.hpp)
set(unit "")
foreach(h ${installed})
  string(APPEND unit "#include <${h}>\n")
endforeach()
file(WRITE ${WORK}/headers/all_headers.cpp "${unit}")
file(WRITE ${WORK}/headers/CMakeLists.txt "cmake_minimum_required(VERSION 3.20)\nproject(pgi_headers CXX)\n"
     "find_package(pgi CONFIG REQUIRED)\nadd_library(all_headers OBJECT all_headers.cpp)\n"
     "target_link_libraries(all_headers PRIVATE pgi::pgi)\n")
run(${CMAKE_COMMAND} -S ${WORK}/headers -B ${WORK}/headers/build -DCMAKE_PREFIX_PATH=${WORK}/prefix)
run(${CMAKE_COMMAND} --build ${WORK}/headers/build)
# The interface needs FLINT and Eigen only (the static library links oneTBB and toml++ privately, found by
# pgiConfig.cmake): no tool's package may appear in the exported targets.
file(READ ${WORK}/prefix/lib/cmake/pgi/pgiTargets.cmake targets)
foreach(dep CLI11 fmt nlohmann doctest)
  if(targets MATCHES "${dep}")
    message(FATAL_ERROR "the installed interface names ${dep}")
  endif()
endforeach()
run(${CMAKE_COMMAND} -S ${SOURCE}/examples -B ${WORK}/example -DCMAKE_PREFIX_PATH=${WORK}/prefix -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK}/example)
run(${WORK}/example/rigid_body)
message("${out}")
if(NOT out MATCHES "Casimir drift [0-9.]+e-1[2-9]")
  message(FATAL_ERROR "the example's Casimir drift is not at round-off:\n${out}")
endif()
# The Python package: importable from another directory once its install directory is on sys.path (under
# /usr/local, Debian's /usr/bin/python3 has it there already).
if(PYTHON AND PYTHON_DIR)
  run(${CMAKE_COMMAND} -E env PYTHONPATH=${WORK}/prefix/${PYTHON_DIR} ${PYTHON} ${SOURCE}/tests/install/import_check.py
      ${WORK}/prefix/)
  message("${out}")
endif()
