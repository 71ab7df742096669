# The LibraryWithoutCli test: cmake -DSOURCE_DIR=<checkout> -DWORK=<scratch folder>
#   -DGENERATOR=Ninja -DMAKE_PROGRAM=<ninja> -P library_only.cmake
# configures the checkout with PHOTOSITE_BUILD_CLI=OFF (no command, tests, benchmarks or Python
# module) and checks, without compiling, that the build graph holds the library and its install
# and nothing of cli/ or bench/cmd/: the generated graph names libphotosite.so and `install`, a dry
# run of `install` finds every input it needs (ninja -n fails on an input that has no rule), and the
# install script installs the library, its headers, the presets and the package files but no
# bin/photosite. The library's objects are the ones the full build compiles (no compile flag
# depends on the option), and InstalledConsumer links and runs a program against them; the full
# library-only build and install are the commands of docs/architecture.md ("Install and
# find_package") with -DPHOTOSITE_BUILD_CLI=OFF.
foreach(v SOURCE_DIR WORK GENERATOR MAKE_PROGRAM)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "library_only.cmake: -D${v}=... is required")
  endif()
endforeach()
file(REMOVE_RECURSE "${WORK}")

function(step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "LibraryWithoutCli: ${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

step("configure" ${CMAKE_COMMAND} -S "${SOURCE_DIR}" -B "${WORK}" -G "${GENERATOR}"
     "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}" -DCMAKE_BUILD_TYPE=Release -DPHOTOSITE_BUILD_CLI=OFF
     -DPHOTOSITE_PYTHON=OFF -DPHOTOSITE_BENCH=OFF)

step("list targets" "${MAKE_PROGRAM}" -C "${WORK}" -t targets all)
set(targets "${step_output}")
foreach(want "\nlibphotosite.so:" "\ninstall:")
  string(FIND "${targets}" "${want}" at)
  if(at EQUAL -1)
    string(STRIP "${want}" w)
    message(FATAL_ERROR "LibraryWithoutCli: the library-only build has no target ${w}")
  endif()
endforeach()
foreach(unwanted "/cli/" "/bench/cmd/" "\nphotosite:" "\nphotosite_tests:")
  string(FIND "${targets}" "${unwanted}" at)
  if(NOT at EQUAL -1)
    string(STRIP "${unwanted}" u)
    message(FATAL_ERROR "LibraryWithoutCli: the library-only build still builds ${u}")
  endif()
endforeach()

step("dry run of install" "${MAKE_PROGRAM}" -C "${WORK}" -n install)

file(READ "${WORK}/cmake_install.cmake" install_script)
foreach(want "/lib/libphotosite.so" "/include\" TYPE DIRECTORY" "/share/photosite/presets"
        "/lib/cmake/photosite/photositeTargets.cmake")
  string(FIND "${install_script}" "${want}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "LibraryWithoutCli: the install script does not install ${want}")
  endif()
endforeach()
string(FIND "${install_script}" "/bin/photosite" at)
if(NOT at EQUAL -1)
  message(FATAL_ERROR "LibraryWithoutCli: the library-only install still installs bin/photosite")
endif()
message("LibraryWithoutCli: ok (${WORK})")
file(REMOVE_RECURSE "${WORK}")
