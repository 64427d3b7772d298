// Test processes: shell commands and the insid binary run as a user runs it, with the exit
// status and what they printed. insid() is there in targets that define INSID_BINARY, the
// binary's path (cli/CMakeLists.txt defines it for the command-line tests).
#pragma once

#include <string>

namespace insid::test {

struct Outcome {
  int status = -1;     // the exit status; 128 + the signal when killed; -1 when not started
  std::string output;  // stdout and stderr
};

/// Runs `command` through the shell with stderr into stdout and waits for it: the exit status
/// (128 + the signal when killed, -1 when it could not be started), what it printed to `output`.
int shell(const std::string& command, std::string* output = nullptr);

/// The Python the external-optimizer tests run.
inline const std::string kPython = "/usr/bin/python3";

#ifdef INSID_SOURCE_DIR
/// The reference external optimizer (a random search) and the misbehaving test client, for
/// targets that define INSID_SOURCE_DIR, the source tree.
inline const std::string kExternalClient =
    std::string(INSID_SOURCE_DIR) + "/scripts/external_random_search.py";
inline const std::string kExternalTestClient =
    std::string(INSID_SOURCE_DIR) + "/optimizers/testdata/external_test_client.py";
#endif

/// What `command` writes to stdout (run through the shell; stderr not captured).
std::string run_command(const std::string& command);

/// Whether kPython imports numpy (the external-optimizer tests skip without it).
bool python_with_numpy();

#ifdef INSID_BINARY
/// Runs `INSID_BINARY args` through the shell (args are shell words) and waits for it.
inline Outcome insid(const std::string& args) {
  Outcome o;
  o.status = shell(std::string(INSID_BINARY) + " " + args, &o.output);
  return o;
}
#endif

}  // namespace insid::test
