// Built-in scenario presets, as JSON texts parsed by the same code as scenario files (so the
// presets are also examples of the documented format). Copies live in scenarios/presets/*.json.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace insid::scenarios {

/// (name, JSON text) of every preset, in a fixed order.
const std::vector<std::pair<std::string, std::string>>& preset_texts();

}  // namespace insid::scenarios
