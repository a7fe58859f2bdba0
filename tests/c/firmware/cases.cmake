# ctest firmware.NAME.list: the test program EXE's --list names exactly CASES (the case table
# entries CMakeLists.txt read from its source, in table order), and `--case` with a name not
# in the table (ARGS: the program's inputs after the options) runs nothing and exits 2
# naming it.
# Usage: cmake -DEXE=path/to/fw_test_NAME -DCASES=a;b;c [-DARGS=...] -P cases.cmake
if(NOT EXE OR NOT CASES)
  message(FATAL_ERROR "cases.cmake: EXE (the test program) and CASES (its case names) must be set")
endif()

execute_process(COMMAND ${EXE} --list RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 10)
string(REPLACE ";" "\n" want "${CASES}")
if(NOT rc STREQUAL "0" OR NOT out STREQUAL "${want}\n" OR NOT err STREQUAL "")
  message(SEND_ERROR "${EXE} --list: exit '${rc}', stdout '${out}', stderr '${err}'; want exit 0 and the "
                     "cases CMake registered, one a line:\n${want}\n(a case table entry not written as "
                     "CHECK_CASE(name)?)")
endif()

execute_process(COMMAND ${EXE} --case no_such_case ${ARGS} RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err TIMEOUT 10)
set(want "${EXE}: --case 'no_such_case': no such case (--list names them)\n")
if(NOT rc STREQUAL "2" OR NOT out STREQUAL "" OR NOT err STREQUAL want)
  message(SEND_ERROR "--case no_such_case: exit '${rc}', stdout '${out}', stderr '${err}'; want exit 2, no "
                     "stdout, stderr '${want}'")
endif()
