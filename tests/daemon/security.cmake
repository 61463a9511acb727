# The security end-to-end test (label daemon): the real dfsmd bound to 0.0.0.0
# with and without a bearer token. Included from tests/daemon/CMakeLists.txt.
dfsm_add_test(dfsmd_security_test
  SOURCES ${PROJECT_SOURCE_DIR}/tests/daemon/dfsmd_security_test.cc
  LIBS dfsm_daemon dfsm_dfsmd_process dfsm_synth LABELS daemon)
target_compile_definitions(dfsmd_security_test PRIVATE DFSMD_BINARY="$<TARGET_FILE:dfsmd>")
add_dependencies(dfsmd_security_test dfsmd)
