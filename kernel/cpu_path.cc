// The kernel's instruction-set path; see cpu_path.h.
#include "kernel/cpu_path.h"

#include <cstdlib>
#include <stdexcept>
#include <string>

#include "kernel/batch_kernel.h"

namespace insid {

namespace {

struct PathInfo {
  const batch_kernel::KernelPath* kernel;
  const char* level;        // GCC's x86-64 micro-architecture level
  const char* description;  // what the CPU must have
  bool cpu_has;
  bool hidden = false;  // by INSID_CPU_HIDE (tests)
};

// The paths this program holds, fastest first, with whether this CPU runs them.
std::vector<PathInfo> probe() {
#if defined(INSID_CPU_DISPATCH_PATHS)
  __builtin_cpu_init();
  return {
      {&kernel_avx512::kPath, "x86-64-v4", "AVX-512 F/BW/CD/DQ/VL",
       __builtin_cpu_supports("x86-64-v4") > 0},
      {&kernel_avx2::kPath, "x86-64-v3", "AVX2, FMA, BMI1/2, F16C, LZCNT, MOVBE",
       __builtin_cpu_supports("x86-64-v3") > 0},
      {&kernel_baseline::kPath, "x86-64", "SSE2 (every x86-64 CPU)", true},
  };
#else
  return {{&kernel_native::kPath, "the build's", "the build machine's instruction set", true}};
#endif
}

std::string names(const std::vector<PathInfo>& paths, bool only_cpu) {
  std::string out;
  for (const PathInfo& p : paths)
    if (!only_cpu || p.cpu_has) out += (out.empty() ? "" : ", ") + std::string(p.kernel->name);
  return out;
}

// probe() less the paths INSID_CPU_HIDE takes away.
std::vector<PathInfo> available() {
  std::vector<PathInfo> paths = probe();
  const char* hide = std::getenv("INSID_CPU_HIDE");
  if (hide == nullptr || *hide == '\0') return paths;
  std::string_view rest(hide);
  while (!rest.empty()) {
    const std::size_t comma = rest.find(',');
    const std::string_view name = rest.substr(0, comma);
    bool known = false;
    for (std::size_t i = 0; i + 1 < paths.size(); ++i)  // never the last (slowest) path
      if (name == paths[i].kernel->name) {
        paths[i].cpu_has = false;
        paths[i].hidden = true;
        known = true;
      }
    if (!known)
      throw std::runtime_error(std::string("INSID_CPU_HIDE=") + hide + ": '" + std::string(name) +
                               "' is not a path that can be hidden (expected " +
                               (paths.size() > 1 ? "avx512 or avx2, comma-separated"
                                                 : "nothing: this build holds one path") +
                               ")");
    rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
  }
  return paths;
}

const PathInfo* find(const std::vector<PathInfo>& paths, std::string_view name) {
  for (const PathInfo& p : paths)
    if (name == p.kernel->name) return &p;
  return nullptr;
}

std::string lacks(const std::vector<PathInfo>& paths, const PathInfo& p, std::string_view what) {
  std::string level = p.level;
  if (!p.hidden) {
    level += " (";
    level += p.description;
    level += ")";
  }
  return std::string(what) + ": this CPU lacks " + level +
         (p.hidden ? " (hidden by INSID_CPU_HIDE)" : "") +
         "; the paths it runs: " + names(paths, true);
}

const batch_kernel::KernelPath& choose() {
  const std::vector<PathInfo> paths = available();
  const char* forced = std::getenv("INSID_CPU");
  if (forced != nullptr && *forced != '\0') {
    const PathInfo* p = find(paths, forced);
    if (p == nullptr) {
      if (paths.size() == 1)
        throw std::runtime_error(std::string("INSID_CPU=") + forced +
                                 ": this build holds one path, " + paths[0].kernel->name +
                                 " (built with INSID_CPU_DISPATCH=OFF); unset INSID_CPU");
      throw std::runtime_error(std::string("INSID_CPU=") + forced +
                               ": expected avx512, avx2 or baseline");
    }
    if (!p->cpu_has) throw std::runtime_error(lacks(paths, *p, std::string("INSID_CPU=") + forced));
    return *p->kernel;
  }
  for (const PathInfo& p : paths)
    if (p.cpu_has) return *p.kernel;
  throw std::logic_error("no kernel path for this CPU");  // the last path always runs
}

}  // namespace

std::vector<std::string> compiled_cpu_paths() {
  std::vector<std::string> out;
  for (const PathInfo& p : probe()) out.emplace_back(p.kernel->name);
  return out;
}

bool cpu_runs_path(std::string_view name) {
  const std::vector<PathInfo> paths = available();
  const PathInfo* p = find(paths, name);
  return p != nullptr && p->cpu_has;
}

const batch_kernel::KernelPath& cpu_path() {
  // Initialised once, thread-safe; a throw leaves it uninitialised, so the next call tries again.
  static const batch_kernel::KernelPath& chosen = choose();
  return chosen;
}

const batch_kernel::KernelPath& cpu_path_named(std::string_view name) {
  const std::vector<PathInfo> paths = available();
  const PathInfo* p = find(paths, name);
  if (p == nullptr)
    throw std::invalid_argument("kernel path '" + std::string(name) + "': this program holds " +
                                names(paths, false));
  if (!p->cpu_has)
    throw std::invalid_argument(lacks(paths, *p, "kernel path " + std::string(name)));
  return *p->kernel;
}

std::string cpu_path_description() { return cpu_path().description; }

}  // namespace insid
