# CTest `install_consumer`: installs the build into a fresh prefix, then uses it as a consumer
# would: configures, builds and runs examples/consumer (find_package(gshell), a shell of
# builtin:sphere through the public API, its report printed), runs the installed CLI, and imports
# the installed Python module. Variables: BUILD_DIR, SOURCE_DIR, WORK_DIR, CXX_COMPILER, and
# optionally CXX_LAUNCHER, CONSUMER_FLAGS, PYTHON, PYTHON_DIR (relative to the prefix).
foreach(var BUILD_DIR SOURCE_DIR WORK_DIR CXX_COMPILER)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "install_consumer_test.cmake: ${var} is not set")
  endif()
endforeach()
set(prefix ${WORK_DIR}/prefix)
file(REMOVE_RECURSE ${WORK_DIR})

# Runs a command; fails the test with its output unless it exits 0. OUT receives its stdout.
# (Arguments are a CMake list: no semicolons inside them.)
function(step name out)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE stdout ERROR_VARIABLE stderr)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name} failed (${rc}): ${ARGN}\n${stdout}\n${stderr}")
  endif()
  message(STATUS "${name}: ok")
  set(${out} "${stdout}" PARENT_SCOPE)
endfunction()

function(expect what actual expected)
  if(NOT "${actual}" STREQUAL "${expected}")
    message(FATAL_ERROR "${what}: got '${actual}', expected '${expected}'")
  endif()
endfunction()

step("install" ignored ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(file include/gshell/shell/generate_shell.h lib/libgshell.a lib/cmake/gshell/gshellConfig.cmake bin/gshell)
  if(NOT EXISTS ${prefix}/${file})
    message(FATAL_ERROR "not installed: ${prefix}/${file}")
  endif()
endforeach()

# CONSUMER_FLAGS (e.g. -march=native while the library is built for any x86-64) checks that the
# pinned Eigen layout lets differently compiled code share Eigen objects.
set(configure_args -S ${SOURCE_DIR}/examples/consumer -B ${WORK_DIR}/build -DCMAKE_PREFIX_PATH=${prefix}
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=${CXX_COMPILER} "-DCMAKE_CXX_FLAGS=${CONSUMER_FLAGS}")
if(CXX_LAUNCHER)
  list(APPEND configure_args -DCMAKE_CXX_COMPILER_LAUNCHER=${CXX_LAUNCHER})
endif()
step("configure consumer" ignored ${CMAKE_COMMAND} ${configure_args})
step("build consumer" ignored ${CMAKE_COMMAND} --build ${WORK_DIR}/build)
step("run consumer" report ${WORK_DIR}/build/shell_of_sphere builtin:sphere 0.05)
message(STATUS "consumer report:\n${report}")
# The icosphere of level 4: 10 * 4^4 + 2 vertices, 20 * 4^4 faces, 3 tets per face; the rigid
# shell of a sphere has no inverted tet.
string(JSON vertices GET "${report}" vertices)
string(JSON faces GET "${report}" faces)
string(JSON tets GET "${report}" tets)
string(JSON method GET "${report}" method)
string(JSON inverted GET "${report}" certificate inverted_tets)
string(JSON valid GET "${report}" valid)
expect("vertices" "${vertices}" 2562)
expect("faces" "${faces}" 5120)
expect("tets" "${tets}" 15360)
expect("method" "${method}" rigid)
expect("inverted tets" "${inverted}" 0)
expect("valid" "${valid}" ON)

step("installed CLI" version ${prefix}/bin/gshell --version)
string(STRIP "${version}" version)
message(STATUS "installed CLI: ${version}")

if(PYTHON AND PYTHON_DIR)
  step("installed Python module" where ${CMAKE_COMMAND} -E env PYTHONPATH=${prefix}/${PYTHON_DIR} PYTHONDONTWRITEBYTECODE=1
       ${PYTHON} -c "import gshell\nV, F = gshell.builtin('sphere:2')\nprint(gshell.__file__, V.shape[0])")
  string(STRIP "${where}" where)
  string(FIND "${where}" "${prefix}/" at)
  expect("Python module location (${where})" "${at}" 0)
  string(REGEX MATCH "[0-9]+$" sphere_vertices "${where}")
  expect("vertices of sphere:2 from Python" "${sphere_vertices}" 162)
endif()
file(REMOVE_RECURSE ${WORK_DIR})
