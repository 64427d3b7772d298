// Damage a binary log reader read past (DataFlash records, ULog messages skipped to the next
// valid one), said the same way by every importer: in the provenance and in one note.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace insid::importers {

/// `prov[key]["skipped"]` = {"places", "bytes", "first"} and the note "N damaged place(s) in the
/// log, B bytes skipped, reading resumed on the next valid `unit`: <the first three places>
/// (provenance.json key.skipped)"; nothing when `places` is 0. `first` lists the first places,
/// each "byte N: why; K bytes skipped to ...".
void record_skipped_damage(std::size_t places, std::size_t bytes,
                           const std::vector<std::string>& first, const std::string& unit,
                           const std::string& key, nlohmann::json& prov,
                           std::vector<std::string>& notes);

/// "; N damaged place(s) skipped (B bytes), first: <the first place>" for an error message that
/// a missing message or topic may owe to the damage; empty when `places` is 0.
std::string skipped_damage_clause(std::size_t places, std::size_t bytes,
                                  const std::vector<std::string>& first);

}  // namespace insid::importers
