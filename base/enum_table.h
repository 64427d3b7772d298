// The names of an enum's values, one table per enum, from which both directions are derived:
//   inline constexpr EnumTable<Termination, 4> kTerminationNames{
//       "termination", {{{Termination::kNone, "running"}, {Termination::kIterations, "iterations"},
//                        ...}}};
//   kTerminationNames.name(Termination::kNone);  // "running"
//   kTerminationNames.value("iterations");       // Termination::kIterations
//   kTerminationNames.value("x");  // std::invalid_argument:
//                                  // termination must be 'running', ... or 'target', got 'x'
// A value may have several names (an alias after its name): name() gives the first, value()
// accepts each. Names are string literals, so name().data() is NUL-terminated.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace insid {

template <class E>
struct EnumName {
  E value;
  std::string_view name;
};

template <class E, std::size_t N>
struct EnumTable {
  /// What the enum names, as the error message's subject ("alignment mode").
  std::string_view what;
  std::array<EnumName<E>, N> entries;

  /// The value's (first) name; std::logic_error for a value the table lacks (a table that
  /// misses an enumerator is a programming error).
  constexpr std::string_view name(E value) const {
    for (const EnumName<E>& e : entries)
      if (e.value == value) return e.name;
    throw std::logic_error(std::string(what) + ": a value without a name in its table");
  }

  /// The value named `text`, if any.
  constexpr std::optional<E> find(std::string_view text) const {
    for (const EnumName<E>& e : entries)
      if (e.name == text) return e.value;
    return std::nullopt;
  }

  /// The value named `text`; std::invalid_argument naming every valid name otherwise.
  E value(std::string_view text) const {
    if (const std::optional<E> v = find(text)) return *v;
    throw std::invalid_argument(std::string(what) + " must be " + quoted_names() + ", got '" +
                                std::string(text) + "'");
  }

  /// Every name, in table order.
  constexpr std::array<std::string_view, N> names() const {
    std::array<std::string_view, N> out{};
    for (std::size_t i = 0; i < N; ++i) out[i] = entries[i].name;
    return out;
  }

  /// "'a'", "'a' or 'b'", "'a', 'b' or 'c'".
  std::string quoted_names() const {
    std::string out;
    for (std::size_t i = 0; i < N; ++i) {
      if (i > 0) out += i + 1 == N ? " or " : ", ";
      out.append("'").append(entries[i].name).append("'");
    }
    return out;
  }
};

}  // namespace insid
