# The AVR image and the simulated board, included by the top-level CMakeLists.txt (after
# firmware/ and protocol/ define navkit_fw_core and navkit_gen).
#
# The image is its own CMake project (firmware/avr/CMakeLists.txt) with the avr-gcc
# toolchain file, built as an ExternalProject into NAVKIT_AVR_IMAGE_DIR on every build (a
# no-op when nothing changed): the core's sources come from the navkit_fw_core target, the
# generated protocol code from this build's gen/ folder.
include(ExternalProject)
# Hz: the crystal of the MCP2515 module the CAN image drives (the common MCP2515 + TJA1050
# module: 8 MHz; some carry 16 MHz). The image's bit timing and the simulated part follow it.
set(NAVKIT_AVR_MCP2515_OSC_HZ 8000000 CACHE STRING "Hz: the MCP2515 module's crystal (8000000 or 16000000)")
get_target_property(navkit_avr_core navkit_fw_core SOURCES)
list(TRANSFORM navkit_avr_core PREPEND ${CMAKE_SOURCE_DIR}/firmware/)
string(JOIN "|" navkit_avr_core_arg ${navkit_avr_core})
# navkit_proto's sources are absolute paths (the generated code and the runtime)
get_target_property(navkit_avr_proto navkit_proto SOURCES)
string(JOIN "|" navkit_avr_proto_arg ${navkit_avr_proto})
set(navkit_avr_outputs)
foreach(n navkit-mega2560 navkit-mega2560-test navkit-mega2560-can)
  list(APPEND navkit_avr_outputs ${NAVKIT_AVR_IMAGE_DIR}/${n}.elf ${NAVKIT_AVR_IMAGE_DIR}/${n}.hex
                                 ${NAVKIT_AVR_IMAGE_DIR}/${n}.size.txt)
endforeach()
ExternalProject_Add(navkit_avr_image
  SOURCE_DIR ${CMAKE_SOURCE_DIR}/firmware/avr
  BINARY_DIR ${NAVKIT_AVR_IMAGE_DIR}
  PREFIX ${CMAKE_BINARY_DIR}/firmware/avr-ep
  CMAKE_GENERATOR ${CMAKE_GENERATOR}
  CMAKE_ARGS
    -DCMAKE_TOOLCHAIN_FILE=${CMAKE_SOURCE_DIR}/cmake/avr-gcc.cmake
    -DNAVKIT_CORE_SOURCES=${navkit_avr_core_arg}
    -DNAVKIT_PROTO_SOURCES=${navkit_avr_proto_arg}
    -DNAVKIT_CORE_DIR=${CMAKE_SOURCE_DIR}/firmware/core
    -DNAVKIT_GEN_DIR=${CMAKE_BINARY_DIR}/gen
    -DNAVKIT_PROTO_RUNTIME_DIR=${CMAKE_SOURCE_DIR}/protocol/runtime
    -DNAVKIT_AVR_RATE_MAX=${NAVKIT_AVR_RATE_MAX}
    -DNAVKIT_AVR_MCP2515_OSC_HZ=${NAVKIT_AVR_MCP2515_OSC_HZ}
  BUILD_ALWAYS ON
  INSTALL_COMMAND ""
  DEPENDS navkit_gen
  BUILD_BYPRODUCTS ${navkit_avr_outputs})

add_subdirectory(${CMAKE_SOURCE_DIR}/firmware/avr/sim ${CMAKE_BINARY_DIR}/firmware/avr-sim)
