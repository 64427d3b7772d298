// Prints the best insid CPU path this machine runs (configure-time check, CMakeLists.txt).
#include <cstdio>
int main() {
  __builtin_cpu_init();
  std::puts(__builtin_cpu_supports("x86-64-v4") ? "avx512"
            : __builtin_cpu_supports("x86-64-v3") ? "avx2"
                                                   : "baseline");
  return 0;
}
