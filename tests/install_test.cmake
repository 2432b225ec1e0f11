# ctest driver for the install tests (InstallStatic, InstallShared): installs SparseMPS of one kind into a scratch
# prefix, then checks the prefix the way users meet it:
#   - the installed headers are exactly the public ones (no private header, none missing);
#   - tests/consumer, a project of its own, finds the package with find_package(SparseMPS), compiles every installed
#     header alone (an installed header including one that is not installed fails here), builds and runs;
#   - the same main.cpp built with `pkg-config --cflags --libs [--static] sparsemps` runs;
#   - the apps (when the prefix has them) are bin/sparsemps-<app>, load the installed library and read their data
#     from share/sparsemps.
# The kind the main build already is (BUILD_SHARED_LIBS) is installed from it, apps included; the other kind is
# configured and built afresh, the library alone.
#
# -D variables: KIND (static | shared), MAIN_BUILD, MAIN_SHARED, APPS (the main build's app names, or empty),
# SOURCE_DIR, WORK, PUBLIC_HEADERS and PRIVATE_HEADERS (paths under lib/), GENERATOR, C_COMPILER, CXX_COMPILER,
# PKG_CONFIG, LDD (may be empty), VERSION.
cmake_minimum_required(VERSION 3.25)

function(run)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "OUTPUT" "")
  execute_process(COMMAND ${arg_UNPARSED_ARGUMENTS} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "install test (${KIND}): step failed (${rc}): ${arg_UNPARSED_ARGUMENTS}\n${out}\n${err}")
  endif()
  if(arg_OUTPUT)
    set(${arg_OUTPUT} "${out}" PARENT_SCOPE)
  endif()
endfunction()

if(KIND STREQUAL "shared")
  set(shared ON)
elseif(KIND STREQUAL "static")
  set(shared OFF)
else()
  message(FATAL_ERROR "KIND must be static or shared, not '${KIND}'")
endif()
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}/prefix")
# Real path: the apps report their data directory from /proc/self/exe, which has no symlinks.
file(REAL_PATH "${WORK}/prefix" prefix)

# 1. Install.
if((shared AND MAIN_SHARED) OR (NOT shared AND NOT MAIN_SHARED))
  run(${CMAKE_COMMAND} --install "${MAIN_BUILD}" --prefix "${prefix}")
else()
  set(APPS "")
  # Unoptimised: the package is under test, not its speed, and the build takes half the time.
  run(${CMAKE_COMMAND} -S "${SOURCE_DIR}" -B "${WORK}/lib" -G "${GENERATOR}" -DCMAKE_BUILD_TYPE=Debug
      -DCMAKE_C_COMPILER=${C_COMPILER} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DBUILD_SHARED_LIBS=${shared}
      -DSPARSEMPS_WERROR=ON -DSPARSEMPS_BUILD_APPS=OFF -DSPARSEMPS_BUILD_TESTS=OFF -DSPARSEMPS_BUILD_BENCH=OFF
      -DSPARSEMPS_BUILD_PYTHON=OFF)
  run(${CMAKE_COMMAND} --build "${WORK}/lib" --parallel 2)
  run(${CMAKE_COMMAND} --install "${WORK}/lib" --prefix "${prefix}")
endif()
if(shared)
  file(GLOB library "${prefix}/lib*/libsparsemps.so")
  set(library_type SHARED_LIBRARY)
else()
  file(GLOB library "${prefix}/lib*/libsparsemps.a")
  set(library_type STATIC_LIBRARY)
endif()
if(NOT library)
  message(FATAL_ERROR "install test (${KIND}): no ${KIND} libsparsemps in ${prefix}")
endif()

# 2. The installed headers are the public ones and the configured mps/version.hpp, nothing else.
file(GLOB_RECURSE installed RELATIVE "${prefix}/include" "${prefix}/include/*")
set(expected ${PUBLIC_HEADERS} mps/version.hpp)
foreach(header IN LISTS PRIVATE_HEADERS)
  if(header IN_LIST installed)
    message(FATAL_ERROR "install test (${KIND}): the private header ${header} is installed")
  endif()
endforeach()
foreach(header IN LISTS installed)
  if(NOT header IN_LIST expected)
    message(FATAL_ERROR "install test (${KIND}): include/${header} is installed but not a public header")
  endif()
endforeach()
foreach(header IN LISTS expected)
  if(NOT header IN_LIST installed)
    message(FATAL_ERROR "install test (${KIND}): the public header ${header} is not installed")
  endif()
endforeach()

# 3. find_package: the consumer project, each installed header compiled alone, the PPE solved by every backend.
run(${CMAKE_COMMAND} -S "${SOURCE_DIR}/tests/consumer" -B "${WORK}/consumer" -G "${GENERATOR}"
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_PREFIX_PATH=${prefix}
    -DEXPECT_LIBRARY_TYPE=${library_type} -DCHECK_HEADERS_IN=${prefix}/include)
run(${CMAKE_COMMAND} --build "${WORK}/consumer" --parallel 2)
run("${WORK}/consumer/consumer" OUTPUT out)
message(STATUS "find_package consumer:\n${out}")

# 4. pkg-config: the same program, compiled and linked with the flags sparsemps.pc gives.
set(pc_env ${CMAKE_COMMAND} -E env "PKG_CONFIG_PATH=${prefix}/lib/pkgconfig")
run(${pc_env} ${PKG_CONFIG} --modversion sparsemps OUTPUT pc_version)
string(STRIP "${pc_version}" pc_version)
if(NOT pc_version STREQUAL VERSION)
  message(FATAL_ERROR "install test (${KIND}): sparsemps.pc says version '${pc_version}', the project ${VERSION}")
endif()
if(shared)
  run(${pc_env} ${PKG_CONFIG} --cflags --libs sparsemps OUTPUT pc_flags)
else()
  run(${pc_env} ${PKG_CONFIG} --static --cflags --libs sparsemps OUTPUT pc_flags)
endif()
separate_arguments(pc_flags UNIX_COMMAND "${pc_flags}")
run(${CXX_COMPILER} -std=c++20 "-DEXPECTED_VERSION=\"${VERSION}\"" "${SOURCE_DIR}/tests/consumer/main.cpp"
    -o "${WORK}/pc-consumer" ${pc_flags})
run(${CMAKE_COMMAND} -E env "LD_LIBRARY_PATH=${prefix}/lib" "${WORK}/pc-consumer" OUTPUT out)
message(STATUS "pkg-config consumer (${pc_flags}):\n${out}")

# 5. The apps: prefixed names, the installed library (found by their RPATH) and the installed data.
foreach(app IN LISTS APPS)
  if(NOT EXISTS "${prefix}/bin/sparsemps-${app}" OR EXISTS "${prefix}/bin/${app}")
    message(FATAL_ERROR "install test (${KIND}): expected bin/sparsemps-${app} and no bin/${app}")
  endif()
endforeach()
if(APPS AND shared AND LDD)
  run(${LDD} "${prefix}/bin/sparsemps-hydrostatic" OUTPUT out)
  if(NOT out MATCHES "libsparsemps[^\n]*=> ${prefix}/bin/\\.\\./lib/libsparsemps")
    message(FATAL_ERROR "install test (${KIND}): the installed app does not load the installed library:\n${out}")
  endif()
endif()
# Each data-reading app, run briefly from the prefix: it must have found share/sparsemps/<data> (a missing file is
# an error, exit 1; a check missed on so short a run is exit 2, fine here) and written that folder to its config.
set(dambreak_args --column classic --end-time 0.01 --frames 0)
set(structure_args --scene csm3 --end-time 0.01 --frames 0)
set(dambreak_data dambreak)
set(structure_data structures)
foreach(app IN ITEMS dambreak structure)
  if(NOT app IN_LIST APPS)
    continue()
  endif()
  execute_process(COMMAND "${prefix}/bin/sparsemps-${app}" ${${app}_args} --out "${WORK}/runs/${app}"
                  WORKING_DIRECTORY "${WORK}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT (rc EQUAL 0 OR rc EQUAL 2))
    message(FATAL_ERROR "install test (${KIND}): installed ${app} failed (${rc}):\n${out}\n${err}")
  endif()
  file(STRINGS "${WORK}/runs/${app}/config.toml" data_line REGEX "^data *=")
  string(REGEX REPLACE "^data *= *\"(.*)\"$" "\\1" data_dir "${data_line}")
  # config.toml writes paths relative to its own folder.
  get_filename_component(data_dir "${WORK}/runs/${app}/${data_dir}" ABSOLUTE)
  get_filename_component(expected "${prefix}/share/sparsemps/${${app}_data}" ABSOLUTE)
  if(NOT data_dir STREQUAL expected)
    message(FATAL_ERROR "install test (${KIND}): installed ${app} read its data from '${data_line}', not the prefix")
  endif()
endforeach()
# The installed scene files, run by the installed sparsemps-run from a folder of the user's: the output goes under it.
if("run" IN_LIST APPS)
  execute_process(COMMAND "${prefix}/bin/sparsemps-run" "${prefix}/share/sparsemps/scenes/hydrostatic.toml"
                          --end-time 0.005 --frames 0
                  WORKING_DIRECTORY "${WORK}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0 OR NOT EXISTS "${WORK}/runs/hydrostatic/summary.json")
    message(FATAL_ERROR "install test (${KIND}): the installed hydrostatic.toml did not run into ./runs (${rc}):\n"
                        "${out}\n${err}")
  endif()
endif()
# 6. The Python module, when the build made it: installed where Debian's Python looks for a prefix (under /usr/local,
# make install's default, lib/python3.X/dist-packages is on its sys.path), importable from there with no PYTHONPATH
# (-I: isolated), finding the installed library by its run path.
file(GLOB module "${prefix}/lib/python3*/dist-packages/sparsemps.*.so")
set(python_checked "")
if(module)
  get_filename_component(site "${module}" DIRECTORY)
  file(RELATIVE_PATH relative "${prefix}" "${site}")
  run(/usr/bin/python3 -I -c "import sys; print('/usr/local/${relative}' in sys.path)" OUTPUT on_path)
  if(NOT on_path MATCHES "True")
    message(FATAL_ERROR "install test (${KIND}): the module went to ${relative}, which /usr/local does not put on "
                        "Debian's Python path")
  endif()
  run(/usr/bin/python3 -I -c "import site; site.addsitedir('${site}'); import sparsemps, numpy as np, scipy.sparse as sp
x, r = sparsemps.solve(sp.identity(5, format='csr') * 2.0, np.ones(5), 'cholmod')
assert sparsemps.__file__.startswith('${site}') and np.allclose(x, 0.5), (sparsemps.__file__, x)
print(sparsemps.__version__)" OUTPUT out)
  set(python_checked ", the Python module")
endif()
list(LENGTH APPS app_count)
message(STATUS "install test (${KIND}): headers, find_package, pkg-config, ${app_count} apps${python_checked} checked")
