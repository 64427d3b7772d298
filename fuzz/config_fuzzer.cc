// libFuzzer target for the config readers: the strict JSON reader (base/json_reader.h) and what
// reads its result, the campaign config (bench/campaign.h, `insid bench --config`) and the
// scenario file (scenarios/scenario.h, `insid simulate --scenario`). The input's first byte
// picks the reader, the rest is the file. A reader must either accept the config or throw
// std::invalid_argument / std::runtime_error with a message; any other exception (a raw
// nlohmann type_error, std::out_of_range, std::bad_alloc), a crash or a sanitizer report is a
// finding.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <string_view>

#include "base/json_reader.h"
#include "bench/campaign.h"
#include "scenarios/scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    const nlohmann::json j = insid::parse_json_strict(text, "fuzz.json");
    if (data[0] % 2 == 0)
      insid::campaign::parse_campaign(j, "fuzz.json");
    else
      insid::scenarios::parse_scenario(j, "fuzz.json");
  } catch (const std::invalid_argument&) {
    // refused with a message: fine
  } catch (const std::runtime_error&) {
    // refused with a message: fine
  } catch (const std::exception& e) {
    std::fprintf(stderr, "finding: neither invalid_argument nor runtime_error: %s\n", e.what());
    std::abort();
  }
  return 0;
}
