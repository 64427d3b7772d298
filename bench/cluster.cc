#include "bench/cluster.h"

#include <cstdlib>
#include <string>

namespace insid::campaign {

int launched_world_size() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}) {
    const char* value = std::getenv(name);
    if (value != nullptr && *value != '\0') {
      const int n = std::atoi(value);
      return n > 0 ? n : 1;
    }
  }
  return 1;
}

}  // namespace insid::campaign
