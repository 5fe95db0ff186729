# Cross build for arm64 (aarch64) with Debian's cross toolchain (crossbuild-essential-arm64) and the
# :arm64 multiarch -dev packages, on an amd64 Debian 12 whose dependencies are arm64 only:
# scripts/check.sh arm64 makes such a root (a chroot) and builds and tests in it. The tests run
# under qemu-user (CMAKE_CROSSCOMPILING_EMULATOR: ctest, gtest_discover_tests and the tests that
# start the ovo command use it).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# find_package/find_library look in /usr/lib/aarch64-linux-gnu (multiarch), never in the build
# machine's own library folders.
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64)
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
# The SIMD kernels (*_simd.cpp): the baseline ARMv8-A ISA, NEON included (-march=native means the
# build machine).
set(OVO_KERNEL_FLAGS "-march=armv8-a" CACHE STRING "Compile flags for SIMD kernel sources (*_simd.cpp)")
