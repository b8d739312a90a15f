# ctest realtime.c_only_consumer: installs modalrt from this build into a scratch prefix, configures
# and builds the C-only project tests/realtime/c_consumer against it (find_package and pkg-config),
# and runs both programs on the lattice basis; then links main.c by hand with
# `pkg-config --static --libs modalrt-static` and checks with readelf that the program does not need
# libmodalrt.so (modalrt.pc's -lmodalrt picks the .so when both are installed) and runs it.
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

# The static pkg-config file: the command line a Makefile would use, then the program's dynamic section.
unset(ENV{LD_LIBRARY_PATH})
file(GLOB_RECURSE static_pc ${prefix}/*/modalrt-static.pc)
if(NOT static_pc)
  message(FATAL_ERROR "modalrt-static.pc was not installed under ${prefix}")
endif()
get_filename_component(pc_dir ${static_pc} DIRECTORY)
set(ENV{PKG_CONFIG_PATH} ${pc_dir})
find_program(PKG_CONFIG pkg-config REQUIRED)
execute_process(COMMAND ${PKG_CONFIG} --static --cflags --libs modalrt-static RESULT_VARIABLE status
                OUTPUT_VARIABLE flags OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "pkg-config --static --libs modalrt-static failed (${status})")
endif()
message("pkg-config --static --cflags --libs modalrt-static: ${flags}")
separate_arguments(flags UNIX_COMMAND "${flags}")
separate_arguments(c_flags UNIX_COMMAND "${C_FLAGS}")
set(program ${WORK_DIR}/consumer_pc_static)
run(${C_COMPILER} ${c_flags} ${SOURCE_DIR}/main.c -o ${program} ${flags} -lm)
find_program(READELF readelf REQUIRED)
execute_process(COMMAND ${READELF} -d ${program} OUTPUT_VARIABLE dynamic RESULT_VARIABLE status)
if(NOT status EQUAL 0 OR dynamic MATCHES "libmodalrt\\.so")
  message(FATAL_ERROR "consumer_pc_static needs libmodalrt.so (or readelf failed):\n${dynamic}")
endif()
message("consumer_pc_static: no libmodalrt.so in its NEEDED entries")
run(${program} ${BASIS})
