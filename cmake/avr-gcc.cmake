# CMake toolchain file for avr-gcc (avr-libc): bare-metal AVR, no OS.
#   cmake -DCMAKE_TOOLCHAIN_FILE=cmake/avr-gcc.cmake [-DNAVKIT_AVR_MCU=atmega2560] ...
# Sets the compiler and binutils (avr-objcopy, avr-size as CMAKE_OBJCOPY/NAVKIT_AVR_SIZE)
# and -mmcu for compiling and linking; the project chooses optimisation and warnings.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR avr)

set(NAVKIT_AVR_MCU atmega2560 CACHE STRING "avr-gcc -mmcu of the target")

find_program(NAVKIT_AVR_GCC avr-gcc)
find_program(NAVKIT_AVR_OBJCOPY avr-objcopy)
find_program(NAVKIT_AVR_SIZE avr-size)
if(NOT NAVKIT_AVR_GCC OR NOT NAVKIT_AVR_OBJCOPY OR NOT NAVKIT_AVR_SIZE)
  message(FATAL_ERROR "avr-gcc, avr-objcopy and avr-size are needed for the AVR image "
                      "(found: '${NAVKIT_AVR_GCC}', '${NAVKIT_AVR_OBJCOPY}', '${NAVKIT_AVR_SIZE}'); run scripts/setup.sh")
endif()
set(CMAKE_C_COMPILER ${NAVKIT_AVR_GCC})
set(CMAKE_ASM_COMPILER ${NAVKIT_AVR_GCC})
set(CMAKE_OBJCOPY ${NAVKIT_AVR_OBJCOPY} CACHE FILEPATH "" FORCE)

set(CMAKE_C_FLAGS_INIT "-mmcu=${NAVKIT_AVR_MCU}")
set(CMAKE_ASM_FLAGS_INIT "-mmcu=${NAVKIT_AVR_MCU}")
set(CMAKE_EXE_LINKER_FLAGS_INIT "-mmcu=${NAVKIT_AVR_MCU}")
# No host libraries or programs: the compiler check builds a static library, not a program.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
