# Sanitizer and fuzzing instrumentation for the whole build, chosen at configure time.
#   -DMOCAP_SANITIZE=address,undefined   ASan + UBSan; any undefined behaviour fails the test
#   -DMOCAP_SANITIZE=thread              TSan (for the threaded units)
#   -DMOCAP_FUZZ=ON                      libFuzzer targets in tests/fuzz (clang only), with the
#                                        code under test instrumented for coverage, ASan and UBSan
# Included before the first target so every library and test is built the same way.
set(MOCAP_SANITIZE "" CACHE STRING "Sanitizers to build with: address,undefined | thread | empty")
option(MOCAP_FUZZ "Build the libFuzzer targets in tests/fuzz (needs clang)" OFF)

if(MOCAP_SANITIZE AND MOCAP_FUZZ)
  message(FATAL_ERROR "MOCAP_FUZZ brings its own sanitizers: leave MOCAP_SANITIZE empty")
endif()

if(MOCAP_SANITIZE)
  if(NOT MOCAP_SANITIZE MATCHES "^(address,undefined|undefined,address|address|undefined|thread)$")
    message(FATAL_ERROR "MOCAP_SANITIZE: address,undefined or thread, not '${MOCAP_SANITIZE}'")
  endif()
  add_compile_options(-fsanitize=${MOCAP_SANITIZE} -fno-omit-frame-pointer)
  add_link_options(-fsanitize=${MOCAP_SANITIZE})
  if(MOCAP_SANITIZE MATCHES "undefined")
    # Undefined behaviour aborts, so a test that triggers it fails instead of printing and passing.
    add_compile_options(-fno-sanitize-recover=undefined)
  endif()
endif()

if(MOCAP_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "MOCAP_FUZZ needs clang (libFuzzer): -DCMAKE_CXX_COMPILER=clang++")
  endif()
  # Coverage for libFuzzer in every library; the harnesses alone link libFuzzer's main.
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
                      -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()
