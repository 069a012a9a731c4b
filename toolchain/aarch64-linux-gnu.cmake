# Cross-compilation for the vision computer (64-bit Arm Linux) with Debian's
# g++-aarch64-linux-gnu and multiarch :arm64 development packages; tests run
# through qemu-user. See toolchain/README.md.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# Multiarch: the :arm64 libraries live in /usr/lib/aarch64-linux-gnu, their CMake
# packages under it; Eigen is header-only and architecture-independent.
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
# The project's own sysroot holds what cannot be installed beside the native
# packages (libyaml-cpp-dev:arm64), unpacked by tools/test --cross aarch64.
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu ${CMAKE_CURRENT_LIST_DIR}/../build/sysroot-arm64)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
# Plain qemu-aarch64-static: with libc6:arm64 installed the arm64 loader is where
# binaries look for it. Do not add -L /usr/aarch64-linux-gnu (mismatched loader and
# libc: every pthread_create spins forever).
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64-static)
