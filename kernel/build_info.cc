// The build's record; see build_info.h.
#include "kernel/build_info.h"

#include <string>

#include "insid_git_revision.h"  // generated at build time (cmake/git_revision.cmake)
#include "kernel/cpu_path.h"

#ifndef INSID_VERSION
#define INSID_VERSION "unknown"
#endif
#ifndef INSID_BUILD_TYPE
#define INSID_BUILD_TYPE "unknown"
#endif

namespace insid {

nlohmann::json build_info_json() {
  nlohmann::json j;
  j["version"] = INSID_VERSION;
  j["git_revision"] = INSID_GIT_REVISION;
  j["build_type"] = INSID_BUILD_TYPE;
  j["cpu_path"] = cpu_path_description();
#if defined(__clang__)
  j["compiler"] = std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
  j["compiler"] = std::string("gcc ") + __VERSION__;
#endif
#ifdef INSID_CXX_FLAGS
  j["flags"] = INSID_CXX_FLAGS;
#endif
  return j;
}

}  // namespace insid
