// `insid` in a CPU-dispatching build (INSID_CPU_DISPATCH, cli/CMakeLists.txt): the program is
// built once per instruction-set path (insid-avx512: x86-64-v4, insid-avx2: x86-64-v3 = AVX2 +
// FMA, insid-baseline: x86-64) and this launcher, built for the baseline so that it runs on any
// x86-64 CPU, replaces itself (execv) with the fastest one this CPU runs. The environment variable
// INSID_CPU=avx512|avx2|baseline forces a path (refused when the CPU lacks it). The program
// records its path in every result's build block (`cpu_path`) and prints it with --version.
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
};

[[noreturn]] void fail(const std::string& message) {
  std::fprintf(stderr, "insid: error: %s\n", message.c_str());
  std::exit(1);
}

std::string self_directory() {
  char buffer[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", buffer, sizeof(buffer) - 1);
  if (n <= 0) fail(std::string("cannot find the insid binaries: readlink /proc/self/exe: ") + std::strerror(errno));
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
      {"avx2", "x86-64-v3", "AVX2, FMA, BMI1/2, F16C, LZCNT, MOVBE", __builtin_cpu_supports("x86-64-v3") > 0},
      {"baseline", "x86-64", "SSE2 (every x86-64 CPU)", true},
  };
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
           chosen->description + "); the paths it runs: " + runs);
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
