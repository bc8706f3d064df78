# Read by ctest after the discovered tests (tests/CMakeLists.txt): the label `long` on the
# tests of tests/long_tests.txt.
file(STRINGS ${CMAKE_CURRENT_LIST_DIR}/long_tests.txt long_tests REGEX "^[^#]")
set_tests_properties(${long_tests} PROPERTIES LABELS long)
