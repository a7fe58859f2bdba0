# ctest firmware_profile_args: fw_test_profile (EXE) refuses a bad --seed or --count with
# exit status 2, nothing on stdout and one message naming the argument and the value
# (before it runs anything: a refused value must not run for ever, as --count -1 did), and
# runs what a good pair asks: 3 moves, and ceil(3/10) = 1 tracked move.
# Usage: cmake -DEXE=path/to/fw_test_profile -P profile_args.cmake
if(NOT EXE)
  message(FATAL_ERROR "profile_args.cmake: EXE (the fw_test_profile binary) is not set")
endif()
set(count_range "1..1000000000")
set(seed_range "0..18446744073709551615")

# bad(OPTION VALUE RANGE): the run must be refused with the option, value and range named.
function(bad opt value range)
  execute_process(COMMAND ${EXE} ${opt} "${value}" RESULT_VARIABLE rc OUTPUT_VARIABLE out
                  ERROR_VARIABLE err TIMEOUT 10)
  set(want "${EXE}: ${opt}: '${value}' is not an integer in ${range}\n")
  if(NOT rc STREQUAL "2" OR NOT out STREQUAL "" OR NOT err STREQUAL want)
    message(SEND_ERROR "${opt} '${value}': exit '${rc}', stdout '${out}', stderr '${err}'; want exit 2, "
                       "no stdout, stderr '${want}'")
  endif()
endfunction()

foreach(value 0 -1 -0 +5 " 5" "7 " x 12x "" 1000000001 99999999999999999999999)
  bad(--count "${value}" ${count_range})
endforeach()
foreach(value -1 x "" 18446744073709551616)
  bad(--seed "${value}" ${seed_range})
endforeach()

# an unknown option or a missing value: refused with its position
execute_process(COMMAND ${EXE} --seed 1 --moves 3 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
                TIMEOUT 10)
if(NOT rc STREQUAL "2" OR NOT out STREQUAL "" OR NOT err MATCHES "argument 3 '--moves': usage")
  message(SEND_ERROR "--moves 3: exit '${rc}', stderr '${err}'; want exit 2 naming argument 3")
endif()
execute_process(COMMAND ${EXE} --count RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 10)
if(NOT rc STREQUAL "2" OR NOT err MATCHES "argument 1 '--count': usage")
  message(SEND_ERROR "--count without a value: exit '${rc}', stderr '${err}'; want exit 2 naming argument 1")
endif()

# a good pair: seed 0x10 is 16, 3 moves and one tracked move
execute_process(COMMAND ${EXE} --seed 0x10 --count 3 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
                TIMEOUT 10)
if(NOT rc STREQUAL "0" OR NOT out MATCHES "property: seed 16, 3 moves, 0 failed"
   OR NOT out MATCHES "tracked property: 1 moves, 0 failed")
  message(SEND_ERROR "--seed 0x10 --count 3: exit '${rc}', stdout '${out}', stderr '${err}'; want 3 moves "
                     "and 1 tracked move")
endif()
