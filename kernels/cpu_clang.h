/* cpu_clang.h -- CPU_CLANG: 1 where the compiler is clang targeting a CPU
 * (x86-64 or AArch64: PoCL), whose builtins PoCL would call rather than
 * inline; lanes.h and vec3.h then use inline forms of them. Other compilers
 * (GPU drivers) keep the standard builtins. The host may set it (tests: 0
 * on PoCL too, to compare both forms).
 * Macros: CPU_CLANG (optional).
 */
#ifndef PYSHADOW_CPU_CLANG_H
#define PYSHADOW_CPU_CLANG_H

#ifndef CPU_CLANG
#if defined(__clang__) && (defined(__x86_64__) || defined(__aarch64__))
#define CPU_CLANG 1
#else
#define CPU_CLANG 0
#endif
#endif

#endif
