# The installed surface, checked (docs/architecture.md, "Public surface"): `cmake --install` of the
# build into a fresh prefix, then
#   - every installed header is under include/cariesim/, is one of the headers users call (ROOTS) or
#     is included by an installed header, and includes only installed headers ("cariesim/...");
#   - tests/install/consumer, configured with find_package(cariesim) against that prefix alone,
#     compiles each of ROOTS on its own and links and runs a program that builds a scene and steps it.
# Run by ctest (label `install`): cmake -DBUILD_DIR= -DSOURCE_DIR= -DWORK_DIR= -DROOTS=a|b|c
#   -DGENERATOR= -DCXX= [-DLAUNCHER=] -P install_test.cmake
cmake_minimum_required(VERSION 3.25)
foreach(var BUILD_DIR SOURCE_DIR WORK_DIR ROOTS GENERATOR CXX)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "install test: ${var} is not set")
  endif()
endforeach()
string(REPLACE "|" ";" roots "${ROOTS}")
set(prefix ${WORK_DIR}/prefix)
file(REMOVE_RECURSE ${WORK_DIR})

# Install.
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix}
  RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "install test: cmake --install failed (${result}):\n${output}")
endif()

# The installed headers: exactly the closure of ROOTS, nothing of src/ and nothing else.
file(GLOB_RECURSE installed RELATIVE ${prefix}/include ${prefix}/include/*)
set(failures)
set(todo ${roots})
set(reached)
while(todo)
  list(POP_FRONT todo header)
  if(header IN_LIST reached)
    continue()
  endif()
  list(APPEND reached ${header})
  if(NOT EXISTS ${prefix}/include/${header})
    list(APPEND failures "${header} is not installed (a header users call, or one an installed header includes)")
    continue()
  endif()
  file(STRINGS ${prefix}/include/${header} quoted REGEX "^[ \t]*#[ \t]*include[ \t]*\"")
  foreach(line IN LISTS quoted)
    string(REGEX REPLACE "^[^\"]*\"([^\"]+)\".*$" "\\1" included "${line}")
    if(included MATCHES "^cariesim/")
      list(APPEND todo ${included})
    else()
      list(APPEND failures "${header} includes \"${included}\", which is no installed header")
    endif()
  endforeach()
endwhile()
foreach(header IN LISTS installed)
  if(NOT header IN_LIST reached)
    list(APPEND failures "include/${header} is installed but no header users call includes it")
  endif()
endforeach()
list(LENGTH installed count)
if(count LESS 10)
  list(APPEND failures "only ${count} headers installed under ${prefix}/include")
endif()
if(NOT EXISTS ${prefix}/lib/cmake/cariesim/cariesimConfig.cmake AND
   NOT EXISTS ${prefix}/lib64/cmake/cariesim/cariesimConfig.cmake)
  list(APPEND failures "no cariesimConfig.cmake installed")
endif()
if(failures)
  list(JOIN failures "\n  " text)
  message(FATAL_ERROR "install test: the installed headers are not the public surface:\n  ${text}")
endif()
message(STATUS "install test: ${count} headers installed, the closure of ${ROOTS}")

# Build the consumer against the prefix alone (no package registry, no source tree).
set(launcher)
if(LAUNCHER)
  set(launcher -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/install/consumer -B ${WORK_DIR}/consumer
    -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX} ${launcher} -DCMAKE_BUILD_TYPE=Release
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCARIESIM_PREFIX=${prefix}
    "-DCARIESIM_ROOTS=${ROOTS}"
  RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "install test: configuring the consumer failed (${result}):\n${output}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/consumer
  RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "install test: building the consumer failed (${result}):\n${output}")
endif()
execute_process(COMMAND ${WORK_DIR}/consumer/cariesim_consumer
  RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "install test: the consumer failed (${result}):\n${output}")
endif()
message(STATUS "install test: the consumer ran:\n${output}")
