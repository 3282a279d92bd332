#!/bin/sh
# CMake compiler/linker launcher for the libFuzzer target: the project builds with the default
# C++ compiler (g++), but -fsanitize=fuzzer needs clang. CMake calls "<launcher> <compiler>
# <args...>"; this drops the compiler and runs $GLINT_FUZZ_CLANGXX (set by CMake in the command
# line as the first argument) with the same arguments.
clangxx="$1"
shift
shift  # the project's compiler
exec "$clangxx" "$@"
