# ctest realtime.c_only_consumer: installs modalrt from this build into a scratch prefix, configures
# and builds the C-only project tests/realtime/c_consumer against it (find_package and pkg-config),
# and runs both programs on the lattice basis.
#   cmake -DMODALRT_BINARY_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -DBASIS=... -DC_COMPILER=... [-DC_FLAGS=...]
#         -P c_consumer.cmake
foreach(variable MODALRT_BINARY_DIR SOURCE_DIR WORK_DIR BASIS C_COMPILER)
  if(NOT DEFINED ${variable})
    message(FATAL_ERROR "c_consumer.cmake: ${variable} is not set")
  endif()
endforeach()

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message("${out}${err}")
  if(NOT status EQUAL 0)
    string(REPLACE ";" " " text "${ARGN}")
    message(FATAL_ERROR "failed (${status}): ${text}")
  endif()
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} --install ${MODALRT_BINARY_DIR} --prefix ${prefix})
# C_FLAGS: the build's own (a sanitizer build's instrumented library needs its runtime linked).
run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/build -DCMAKE_C_COMPILER=${C_COMPILER}
    "-DCMAKE_C_FLAGS=${C_FLAGS}" -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer_static ${BASIS})
# The pkg-config program links the shared library (-lmodalrt finds libmodalrt.so first).
set(ENV{LD_LIBRARY_PATH} "${prefix}/lib:$ENV{LD_LIBRARY_PATH}")
run(${WORK_DIR}/build/consumer_pkg_config ${BASIS})
