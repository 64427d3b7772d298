// The instruction-set path of the batched fitness kernel (kernel/batch_kernel.h): the
// paths this program holds, the ones this CPU runs, and the one it uses.
//
// Under CPU dispatch (the default x86-64 build, CMakeLists.txt INSID_CPU_DISPATCH) the program
// holds three: avx512 (x86-64-v4), avx2 (x86-64-v3: AVX2 + FMA) and baseline (x86-64), and the
// rest of the program is baseline x86-64. Without it, one: "native", the build's own instruction
// set. The environment variable INSID_CPU=avx512|avx2|baseline forces a path; one this CPU lacks
// is refused. For tests only, INSID_CPU_HIDE=avx512[,avx2] treats those paths as missing from
// this CPU (it can only take paths away, never claim one the CPU lacks).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace insid {

namespace batch_kernel {
struct KernelPath;
}

/// The paths compiled into this program, fastest first.
std::vector<std::string> compiled_cpu_paths();

/// Whether this CPU runs the named path (false for a name not compiled in; INSID_CPU_HIDE counts).
/// Throws std::runtime_error on a bad INSID_CPU_HIDE.
bool cpu_runs_path(std::string_view name);

/// The path the program uses: INSID_CPU's when set, else the fastest this CPU runs. Decided on
/// the first call; throws std::runtime_error naming the variable, its value and the paths this
/// CPU runs when INSID_CPU or INSID_CPU_HIDE is bad (every call, until the environment is fixed).
const batch_kernel::KernelPath& cpu_path();

/// A path by name, for tests that run each path the CPU has: throws std::invalid_argument when
/// the program does not hold it or this CPU lacks it.
const batch_kernel::KernelPath& cpu_path_named(std::string_view name);

/// cpu_path()'s description, e.g. "avx512 (kernel for x86-64-v4: AVX-512; the rest x86-64)":
/// printed by --version and recorded in every result's build block (`cpu_path`).
std::string cpu_path_description();

}  // namespace insid
