// `insid` in a CPU-dispatching build (INSID_CPU_DISPATCH, cli/CMakeLists.txt): the program is
// built once per instruction-set path (insid-avx512: x86-64-v4, insid-avx2: x86-64-v3 = AVX2 +
// FMA, insid-baseline: x86-64) and this launcher, built for the baseline so that it runs on any
// x86-64 CPU, replaces itself (execv) with the fastest one this CPU runs. The environment variable
// INSID_CPU=avx512|avx2|baseline forces a path (refused when the CPU lacks it). The program
// records its path in every result's build block (`cpu_path`) and prints it with --version.
//
// For tests only: INSID_CPU_HIDE=avx512[,avx2] makes the launcher treat those paths as missing
// from this CPU, so that the refusal of a forced path the CPU lacks, and the fall-back to the next
// path, can be tested on a CPU that has them (scripts/test_cpu_paths.py). It can only take paths
// away, never claim one the CPU lacks.
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

namespace {

struct CpuPath {
  const char* name;         // INSID_CPU value and binary suffix
  const char* level;        // GCC's x86-64 micro-architecture level
  const char* description;  // what the CPU must have
  bool supported;
  bool hidden = false;  // by INSID_CPU_HIDE (tests)
};

[[noreturn]] void fail(const std::string& message) {
  std::fprintf(stderr, "insid: error: %s\n", message.c_str());
  std::exit(1);
}

std::string self_directory() {
  char buffer[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", buffer, sizeof(buffer) - 1);
  if (n <= 0)
    fail(std::string("cannot find the insid binaries: readlink /proc/self/exe: ") +
         std::strerror(errno));
  buffer[n] = '\0';
  std::string path(buffer);
  return path.substr(0, path.rfind('/'));
}

}  // namespace

int main(int argc, char** argv) {
  (void)argc;
  __builtin_cpu_init();
  CpuPath paths[] = {
      {"avx512", "x86-64-v4", "AVX-512 F/BW/CD/DQ/VL", __builtin_cpu_supports("x86-64-v4") > 0},
      {"avx2", "x86-64-v3", "AVX2, FMA, BMI1/2, F16C, LZCNT, MOVBE",
       __builtin_cpu_supports("x86-64-v3") > 0},
      {"baseline", "x86-64", "SSE2 (every x86-64 CPU)", true},
  };
  if (const char* hide = std::getenv("INSID_CPU_HIDE"); hide != nullptr && *hide != '\0') {
    std::string_view rest(hide);
    while (!rest.empty()) {
      const std::size_t comma = rest.find(',');
      const std::string_view name = rest.substr(0, comma);
      bool known = false;
      for (CpuPath& p : paths)
        if (name == p.name && name != "baseline") {
          p.supported = false;
          p.hidden = true;
          known = true;
        }
      if (!known)
        fail(std::string("INSID_CPU_HIDE=") + hide + ": '" + std::string(name) +
             "' is not a path that can be hidden (expected avx512 or avx2, comma-separated)");
      rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
    }
  }
  const std::string dir = self_directory();
  auto binary = [&](const CpuPath& p) { return dir + "/insid-" + p.name; };
  const char* forced = std::getenv("INSID_CPU");
  const CpuPath* chosen = nullptr;
  if (forced != nullptr && *forced != '\0') {
    for (const CpuPath& p : paths)
      if (std::string_view(forced) == p.name) chosen = &p;
    if (chosen == nullptr)
      fail(std::string("INSID_CPU=") + forced + ": expected avx512, avx2 or baseline");
    if (!chosen->supported) {
      std::string runs;
      for (const CpuPath& p : paths)
        if (p.supported) runs += (runs.empty() ? "" : ", ") + std::string(p.name);
      fail(std::string("INSID_CPU=") + forced + ": this CPU lacks " + chosen->level + " (" +
           chosen->description + ")" + (chosen->hidden ? " (hidden by INSID_CPU_HIDE)" : "") +
           "; the paths it runs: " + runs);
    }
    if (access(binary(*chosen).c_str(), X_OK) != 0)
      fail(std::string("INSID_CPU=") + forced + ": " + binary(*chosen) + " is not there (" +
           std::strerror(errno) + "); rebuild insid");
  } else {
    for (const CpuPath& p : paths)
      if (p.supported && access(binary(p).c_str(), X_OK) == 0) {
        chosen = &p;
        break;
      }
    if (chosen == nullptr)
      fail("no insid program for this CPU next to the launcher in " + dir +
           " (expected insid-avx512, insid-avx2 or insid-baseline); rebuild insid");
  }
  const std::string path = binary(*chosen);
  execv(path.c_str(), argv);
  fail("cannot run " + path + ": " + std::strerror(errno));
}
