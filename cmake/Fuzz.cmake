# The libFuzzer targets (tests/fuzz), added after the libraries they exercise; see Sanitizers.cmake.
if(MOCAP_FUZZ)
  add_subdirectory(tests/fuzz)
endif()
