// The build that produced a result: recorded in every result file and printed by --version.
#pragma once

#include <nlohmann/json.hpp>

namespace insid {

/// Version, git revision, build type, compiler and the kernel's instruction-set path
/// (kernel/cpu_path.h).
nlohmann::json build_info_json();

}  // namespace insid
