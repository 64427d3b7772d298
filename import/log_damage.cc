#include "import/log_damage.h"

namespace insid::importers {

void record_skipped_damage(std::size_t places, std::size_t bytes,
                           const std::vector<std::string>& first, const std::string& unit,
                           const std::string& key, nlohmann::json& prov,
                           std::vector<std::string>& notes) {
  if (places == 0) return;
  constexpr std::size_t kInNote = 3;
  prov[key]["skipped"] = {{"places", places}, {"bytes", bytes}, {"first", first}};
  std::string listed;
  for (std::size_t k = 0; k < first.size() && k < kInNote; ++k)
    listed += (k ? "; " : "") + first[k];
  notes.push_back(std::to_string(places) + " damaged place(s) in the log, " +
                  std::to_string(bytes) + " bytes skipped, reading resumed on the next valid " +
                  unit + ": " + listed + (places > kInNote ? "; ..." : "") + " (provenance.json " +
                  key + ".skipped)");
}

std::string skipped_damage_clause(std::size_t places, std::size_t bytes,
                                  const std::vector<std::string>& first) {
  if (places == 0) return "";
  return "; " + std::to_string(places) + " damaged place" + (places == 1 ? "" : "s") +
         " skipped (" + std::to_string(bytes) +
         " bytes), first: " + (first.empty() ? std::string("(not listed)") : first.front());
}

}  // namespace insid::importers
