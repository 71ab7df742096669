# The InstalledConsumer test: cmake -DBUILD_DIR=<photosite build> -DSOURCE_DIR=<checkout>
#   -DWORK=<scratch folder> -P run.cmake
# installs the built library into WORK/prefix, configures and builds tests/consumer against it
# with find_package(photosite), and runs it with no PHOTOSITE_* data variables set, so the
# presets must be found relative to the installed library. Every step failing fails the test.
foreach(v BUILD_DIR SOURCE_DIR WORK)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "run.cmake: -D${v}=... is required")
  endif()
endforeach()
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")
set(prefix "${WORK}/prefix")

function(step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "InstalledConsumer: ${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

step("install" ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${prefix}")
# The public headers only: no private *_detail.h and no third-party include in any of them.
file(GLOB_RECURSE headers "${prefix}/include/photosite/*")
if(NOT headers)
  message(FATAL_ERROR "InstalledConsumer: no headers installed under ${prefix}/include/photosite")
endif()
foreach(h ${headers})
  if(h MATCHES "_detail\\.h$")
    message(FATAL_ERROR "InstalledConsumer: private header installed: ${h}")
  endif()
  file(STRINGS "${h}" includes REGEX "^#include <(nlohmann|opencv|OpenImageIO|fmt|toml)")
  if(includes)
    message(FATAL_ERROR "InstalledConsumer: ${h} includes a third-party header: ${includes}")
  endif()
endforeach()

# An AddressSanitizer build's library (-DSANITIZE=ON) needs the ASan runtime first in the
# program's library list, so its consumer is built with the same -fsanitize flags (else the
# runtime refuses to start: "ASan runtime does not come first in initial library list").
set(san_flags)
if(SANITIZE)
  set(san_flags "-DCMAKE_CXX_FLAGS=-fsanitize=address,undefined"
                "-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=address,undefined")
endif()
step("configure" ${CMAKE_COMMAND} -S "${SOURCE_DIR}/tests/consumer" -B "${WORK}/build" -G Ninja
     -DCMAKE_BUILD_TYPE=Release "-DCMAKE_PREFIX_PATH=${prefix}" ${san_flags})
step("build" ${CMAKE_COMMAND} --build "${WORK}/build")
step("run" ${CMAKE_COMMAND} -E env --unset=PHOTOSITE_PRESET_DIR --unset=PHOTOSITE_DATA_DIR
     "${WORK}/build/consumer")
message("${step_output}")
if(NOT step_output MATCHES "consumer: ok")
  message(FATAL_ERROR "InstalledConsumer: the consumer's check did not pass")
endif()
# The presets came from the installed tree, found relative to libphotosite.so.
string(FIND "${step_output}" "preset ${prefix}/share/photosite/presets/cameras/onsemi-ar0331.toml" at)
if(at EQUAL -1)
  message(FATAL_ERROR "InstalledConsumer: the preset was not read from ${prefix}/share/photosite")
endif()
file(REMOVE_RECURSE "${WORK}")
