# Reliability tests of dfsmd (faults and soak), included from
# tests/daemon/CMakeLists.txt.
#  - dfsmd_fault_test: state directory full (tmpfs; skips without root),
#    pathological bursts, corrupt and truncated frames (label daemon).
#  - dfsmd_kill_test: kill -9 at random points, 24 rounds (label daemon).
#  - dfsmd_amplification_test: peak RSS under the memory-amplification
#    attacks at the default configuration (label daemon).
#  - dfsmd_memory_budget_test: the 1 GB profile runs 1080p jobs in a memory
#    cgroup with its drop-in's MemoryMax (label daemon; skips without root).
#  - device_gone_test: capture device unplugged under the REST API (fake V4L2
#    driver, in process; label daemon).
#  - dfsmd_soak_test: 1000 triggers; skips unless DFSM_TEST_SOAK=1 (label soak).
foreach(test dfsmd_fault_test dfsmd_kill_test dfsmd_amplification_test dfsmd_memory_budget_test
    dfsmd_soak_test)
  if(test STREQUAL "dfsmd_soak_test")
    set(_labels soak)
  else()
    set(_labels daemon)
  endif()
  # The kill -9 test is the longest of the daemon tests (~75 s under TSan):
  # started first, the others run beside it.
  set(_cost)
  if(test STREQUAL "dfsmd_kill_test")
    set(_cost COST 1000)
  endif()
  dfsm_add_test(${test}
    SOURCES ${PROJECT_SOURCE_DIR}/tests/daemon/${test}.cc
    LIBS dfsm_daemon dfsm_dfsmd_process dfsm_fault_helpers dfsm_synth dfsm_pipeline dfsm_tar_files
    LABELS ${_labels} ${_cost})
  target_compile_definitions(${test} PRIVATE DFSMD_BINARY="$<TARGET_FILE:dfsmd>")
  add_dependencies(${test} dfsmd)
endforeach()
if(TARGET dfsm_capture_fake)
  dfsm_add_test(device_gone_test SOURCES ${PROJECT_SOURCE_DIR}/tests/daemon/device_gone_test.cc
    LIBS dfsm_daemon dfsm_capture_fake LABELS daemon)
endif()
