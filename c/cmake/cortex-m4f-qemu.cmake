# Toolchain: libsail's tests for Cortex-M4F, run on QEMU's mps2-an386 (make cross-test).
# The compiler flags are make cross's (cortex-m4f.cmake); the programs link newlib-nano with
# semihosting (rdimon: stdout, files, argv and the exit status through the host), float printf
# and scanf, the start-up code in c/qemu/startup.c and the board's memory map.
include(${CMAKE_CURRENT_LIST_DIR}/cortex-m4f.cmake)
set(SAIL_QEMU ON CACHE BOOL "Link the tests for QEMU's mps2-an386" FORCE)
set(CMAKE_EXE_LINKER_FLAGS_INIT "--specs=nano.specs --specs=rdimon.specs -u _printf_float -u _scanf_float -Wl,--gc-sections -T ${CMAKE_CURRENT_LIST_DIR}/../qemu/mps2_an386.ld")
set(CMAKE_CROSSCOMPILING_EMULATOR ${CMAKE_CURRENT_LIST_DIR}/../qemu/run.sh)
