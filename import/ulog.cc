#include "import/ulog.h"
#include "base/file_read.h"
#include "import/log_damage.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace insid::importers {
namespace {

constexpr unsigned char kMagic[7] = {'U', 'L', 'o', 'g', 0x01, 0x12, 0x35};
constexpr std::size_t kHeaderSize = 16;
constexpr std::size_t kMessageHeaderSize = 3;  // uint16 size, uint8 type
constexpr unsigned char kSyncMagic[8] = {0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12};
constexpr std::size_t kSkipsListed = 20;

const std::map<std::string, std::size_t>& basic_types() {
  static const std::map<std::string, std::size_t> types = {
      {"int8_t", 1},  {"uint8_t", 1},  {"int16_t", 2}, {"uint16_t", 2},
      {"int32_t", 4}, {"uint32_t", 4}, {"int64_t", 8}, {"uint64_t", 8},
      {"float", 4},   {"double", 8},   {"bool", 1},    {"char", 1}};
  return types;
}

template <class T>
T load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);  // ULog is little-endian, as every machine insid targets
  return v;
}

double decode(const std::string& type, const char* p) {
  if (type == "float") return load<float>(p);
  if (type == "double") return load<double>(p);
  if (type == "int8_t") return load<std::int8_t>(p);
  if (type == "uint8_t" || type == "bool" || type == "char") return load<std::uint8_t>(p);
  if (type == "int16_t") return load<std::int16_t>(p);
  if (type == "uint16_t") return load<std::uint16_t>(p);
  if (type == "int32_t") return load<std::int32_t>(p);
  if (type == "uint32_t") return load<std::uint32_t>(p);
  if (type == "int64_t") return static_cast<double>(load<std::int64_t>(p));
  return static_cast<double>(load<std::uint64_t>(p));  // uint64_t
}

}  // namespace

UlogFile UlogFile::read(const std::string& path) {
  FileReadOptions options;
  options.magic = kUlogMagic;
  options.magic_name = "a PX4 ULog (magic 'ULog' 01 12 35)";
  return parse(read_file_whole(path, path, options), path);
}

void UlogFile::resolve_formats() {
  formats_.clear();
  damaged_formats_.clear();
  // Formats: "name:type field;type[n] field;...". One that cannot be read is set aside with the
  // byte of its 'F' message: it costs the topics that use it, not the log.
  for (const auto& [text, offset] : format_texts_) {
    const std::string at = "byte " + std::to_string(offset);
    const std::size_t colon = text.find(':');
    if (colon == std::string::npos || colon == 0) {
      damaged_formats_["(no name)"] =
          at + ": expected 'name:fields' in '" + text.substr(0, 60) + "'";
      continue;
    }
    const std::string name = text.substr(0, colon);
    Format fmt;
    fmt.byte = offset;
    std::string damage;
    std::size_t start = colon + 1;
    while (start < text.size() && damage.empty()) {
      std::size_t end = text.find(';', start);
      if (end == std::string::npos) end = text.size();
      const std::string item = text.substr(start, end - start);
      start = end + 1;
      if (item.empty()) continue;
      const std::size_t space = item.find(' ');
      if (space == std::string::npos) {
        damage = "field '" + item + "' is not 'type name'";
        break;
      }
      Field field;
      field.type = item.substr(0, space);
      field.name = item.substr(space + 1);
      if (const std::size_t br = field.type.find('['); br != std::string::npos) {
        const std::size_t close = field.type.find(']', br);
        if (close == std::string::npos) {
          damage = "field '" + item + "': unclosed '['";
          break;
        }
        try {
          field.count = std::stoul(field.type.substr(br + 1, close - br - 1));
        } catch (const std::exception&) {
          damage = "field '" + item + "': array size is not a number";
          break;
        }
        if (field.count == 0 || field.count > 65535) {
          damage = "field '" + item + "': array size out of range";
          break;
        }
        field.type = field.type.substr(0, br);
      }
      fmt.fields.push_back(field);
    }
    if (!damage.empty())
      damaged_formats_[name] = at + ": " + damage;
    else
      formats_[name] = fmt;
  }
  // Sizes and offsets, nested formats resolved; a format with a type that is neither basic nor
  // a readable format (damaged, or not in the file), or that nests itself, is set aside too.
  for (bool changed = true; changed;) {
    changed = false;
    for (auto it = formats_.begin(); it != formats_.end();) {
      auto& [name, fmt] = *it;
      std::size_t offset = 0;
      bool complete = true;
      std::string damage;
      for (Field& field : fmt.fields) {
        const auto basic = basic_types().find(field.type);
        std::size_t element = basic != basic_types().end() ? basic->second : 0;
        if (element == 0) {
          const auto nested = formats_.find(field.type);
          if (nested == formats_.end()) {
            damage = "field '" + field.name + "': unknown type '" + field.type + "'" +
                     (damaged_formats_.count(field.type) ? " (its own format is damaged)" : "");
            break;
          }
          element = nested->second.size;
          if (element == 0) complete = false;
        }
        field.offset = offset;
        field.element_size = element;
        offset += element * field.count;
      }
      if (!damage.empty()) {
        damaged_formats_[name] = "byte " + std::to_string(fmt.byte) + ": " + damage;
        it = formats_.erase(it);
        changed = true;
        continue;
      }
      if (complete && fmt.size != offset) {
        fmt.size = offset;
        fmt.logged_size = 0;  // the logger leaves out the padding at the end, nothing else
        for (const Field& field : fmt.fields)
          if (field.name.rfind("_padding", 0) != 0)
            fmt.logged_size = field.offset + field.element_size * field.count;
        changed = true;
      }
      ++it;
    }
  }
  for (auto it = formats_.begin(); it != formats_.end();) {
    if (it->second.size == 0 && !it->second.fields.empty()) {
      damaged_formats_[it->first] =
          "byte " + std::to_string(it->second.byte) + ": the format nests itself";
      it = formats_.erase(it);
    } else {
      ++it;
    }
  }
  resolved_texts_ = format_texts_.size();
}

std::size_t UlogFile::message_length(std::size_t q, bool strict) const {
  const std::string& b = bytes_;
  if (b.size() - q < kMessageHeaderSize) return 0;
  const std::size_t size = load<std::uint16_t>(b.data() + q);
  const char type = b[q + 2];
  const std::size_t body = q + kMessageHeaderSize;
  if (body + size > b.size()) return 0;
  const char* p = b.data() + body;
  const auto text_ok = [](const char* t, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i)
      if (t[i] < 0x20 || t[i] > 0x7e) return false;
    return true;
  };
  const auto key_ok = [&](std::size_t len_at) {  // uint8 key_len, then the key
    if (size <= len_at) return false;
    const std::size_t key_len = static_cast<unsigned char>(p[len_at]);
    return key_len > 0 && len_at + 1 + key_len <= size && text_ok(p + len_at + 1, key_len);
  };
  bool ok = false;
  switch (type) {
    case 'F': {
      const std::string_view text(p, size);
      const std::size_t colon = text.find(':');
      ok = size >= 3 && colon != std::string_view::npos && colon > 0 && text_ok(p, size);
      break;
    }
    case 'I':
    case 'P':
      ok = key_ok(0);
      break;
    case 'M':
    case 'Q':
      ok = key_ok(1);
      break;
    case 'A': {
      if (size < 4 || !text_ok(p + 3, size - 3)) break;
      const auto id = load<std::uint16_t>(p + 1);
      const auto it = subscriptions_.find(id);
      ok = !strict || it == subscriptions_.end() ||
           (it->second.topic == std::string_view(p + 3, size - 3) &&
            it->second.multi_id == static_cast<unsigned char>(p[0]));
      break;
    }
    case 'D': {
      if (size < 2) break;
      if (!strict) {
        ok = true;
        break;
      }
      const auto it = subscriptions_.find(load<std::uint16_t>(p));
      if (it == subscriptions_.end()) break;
      const auto fmt = formats_.find(it->second.topic);
      ok = fmt == formats_.end() ||
           (size - 2 <= fmt->second.size && size - 2 >= fmt->second.logged_size);
      break;
    }
    case 'O':
    case 'R':
      ok = size == 2;  // uint16 duration (ms) / uint16 msg_id
      break;
    case 'L':  // char log_level '0' (EMERG) .. '7' (DEBUG), uint64 timestamp, text
      ok = size >= 9 && p[0] >= '0' && p[0] <= '7';
      break;
    case 'C':  // char log_level, uint16 tag, uint64 timestamp, text
      ok = size >= 11 && p[0] >= '0' && p[0] <= '7';
      break;
    case 'S':
      ok = size == sizeof kSyncMagic && std::memcmp(p, kSyncMagic, sizeof kSyncMagic) == 0;
      break;
    default:
      break;
  }
  return ok ? kMessageHeaderSize + size : 0;
}

UlogFile UlogFile::parse(std::string bytes, const std::string& where) {
  UlogFile f;
  f.where_ = where;
  f.bytes_ = std::move(bytes);
  const std::string& b = f.bytes_;
  const std::size_t n = b.size();
  if (n < kHeaderSize || std::memcmp(b.data(), kMagic, sizeof kMagic) != 0)
    throw std::runtime_error(where +
                             ": byte 0: not a ULog file (expected the magic 'ULog' 01 12 35)");
  f.version_ = static_cast<unsigned char>(b[7]);
  if (f.version_ > 1)
    throw std::runtime_error(where + ": byte 7: ULog version " + std::to_string(f.version_) +
                             " is newer than the version 1 insid reads");
  f.start_us_ = load<std::uint64_t>(b.data() + 8);

  // The file's end, or a message cut by it (the logger stopped mid-write).
  const auto ends_file = [&](std::size_t q) {
    return n - q < kMessageHeaderSize ||
           q + kMessageHeaderSize + load<std::uint16_t>(b.data() + q) > n;
  };
  // Formats are read before the data section needs them (a 'D' is checked against its format),
  // and again whenever more 'F' messages came since.
  const auto formats_current = [&] {
    if (f.resolved_texts_ != f.format_texts_.size()) f.resolve_formats();
  };
  // A message at q is taken when it is well formed and followed by another (checked without the
  // subscriptions, which q may be adding), by the file's end, by a message the end cuts, or by
  // one message of an unknown type (a damaged type byte) whose size leads to a well-formed one:
  // a damaged size field rarely leads to a well-formed header.
  const auto continues = [&](std::size_t r) {
    if (ends_file(r) || f.message_length(r, false) > 0) return true;
    const std::size_t r2 = r + kMessageHeaderSize + load<std::uint16_t>(b.data() + r);
    return r2 == n || f.message_length(r2, false) > 0;
  };
  const auto valid_pair = [&](std::size_t q) -> std::size_t {  // its length, 0 if not
    const std::size_t len = f.message_length(q, true);
    return len > 0 && continues(q + len) ? len : 0;
  };
  const auto next_valid = [&](std::size_t from) -> std::size_t {
    for (std::size_t q = from; q + kMessageHeaderSize <= n; ++q)
      if (valid_pair(q) > 0) return q;
    return n;
  };
  // Damage inside the log: skipped to the next valid message, counted and named; a log with no
  // valid message after the damage keeps what came before it, and says so.
  const auto skip = [&](std::size_t at, const std::string& why) -> std::size_t {
    const std::size_t resume = next_valid(at + 1);
    if (resume == n) {
      f.truncation_ = "byte " + std::to_string(at) + ": " + why + "; no valid message after it (" +
                      std::to_string(n - at) + " bytes ignored)";
      return n;
    }
    f.skipped_bytes_ += resume - at;
    if (f.skips_.size() < kSkipsListed)
      f.skips_.push_back("byte " + std::to_string(at) + ": " + why + "; " +
                         std::to_string(resume - at) +
                         " bytes skipped to the next message at byte " + std::to_string(resume));
    ++f.skip_count_;
    return resume;
  };

  std::vector<std::uint64_t> appended;
  std::size_t pos = kHeaderSize;
  if (n - pos >= kMessageHeaderSize && b[pos + 2] == 'B') {
    // Flag bits, when present, are the first message (ULog spec: "Flag Bits Message").
    const std::size_t size = load<std::uint16_t>(b.data() + pos);
    const std::string at = where + ": byte " + std::to_string(pos) + ", 'B' message";
    if (size < 40 || pos + kMessageHeaderSize + size > n)
      throw std::runtime_error(at + ": " + std::to_string(size) +
                               " bytes, expected 40 (flag bits) within the file");
    const char* p = b.data() + pos + kMessageHeaderSize;
    const auto incompat = static_cast<unsigned char>(p[8]);
    if ((incompat & ~1u) != 0 || std::memcmp(p + 9, "\0\0\0\0\0\0\0", 7) != 0)
      throw std::runtime_error(at + ": incompatible flags set that insid does not know");
    if (incompat & 1u)
      for (int k = 0; k < 3; ++k)
        if (const auto off = load<std::uint64_t>(p + 16 + 8 * k); off > 0) appended.push_back(off);
    pos += kMessageHeaderSize + size;
  }
  while (pos < n) {
    if (!appended.empty() && pos > appended.front()) appended.erase(appended.begin());
    if (ends_file(pos)) {
      // Cut by the file's end, unless a valid message follows (then its size field is damaged).
      if (n - pos >= kMessageHeaderSize && next_valid(pos + 1) < n) {
        pos = skip(pos, "a message whose size field runs past the file's end");
        continue;
      }
      f.truncation_ = n - pos < kMessageHeaderSize
                          ? "the file ends inside a message header at byte " + std::to_string(pos)
                          : "the file ends inside a '" + std::string(1, b[pos + 2]) +
                                "' message at byte " + std::to_string(pos) + " (" +
                                std::to_string(n - pos) +
                                " bytes ignored; the logger stopped mid-write)";
      break;
    }
    const std::size_t size = load<std::uint16_t>(b.data() + pos);
    const char type = b[pos + 2];
    const std::size_t body = pos + kMessageHeaderSize;
    // Appended data: a message that would run past the next appended offset is cut there.
    if (!appended.empty() && body + size > appended.front() && pos < appended.front()) {
      pos = static_cast<std::size_t>(appended.front());
      appended.erase(appended.begin());
      continue;
    }
    if (type == 'A' || type == 'D') formats_current();
    if (valid_pair(pos) == 0) {
      pos = skip(pos, f.why_not_valid(pos));
      continue;
    }
    const char* p = b.data() + body;
    switch (type) {
      case 'F':
        f.format_texts_.emplace_back(std::string(p, size), pos);
        break;
      case 'A': {
        Subscription s;
        s.multi_id = static_cast<unsigned char>(p[0]);
        s.topic.assign(p + 3, size - 3);
        s.byte = pos;
        f.subscriptions_[load<std::uint16_t>(p + 1)] = s;
        break;
      }
      case 'D':
        f.data_[load<std::uint16_t>(p)].emplace_back(body + 2, size - 2);
        break;
      case 'O':
        f.dropouts_ms_ += load<std::uint16_t>(p);
        ++f.dropout_count_;
        break;
      default:
        break;  // information, parameters, log text, sync, unsubscription: not needed here
    }
    pos = body + size;
  }
  formats_current();
  // Data longer than its format (when the format came after the data): the message is damage.
  for (auto& [id, messages] : f.data_) {
    const auto sub = f.subscriptions_.find(id);
    const auto fmt = f.formats_.find(sub->second.topic);
    if (fmt == f.formats_.end()) continue;
    const std::size_t before = messages.size();
    std::size_t first = 0;
    messages.erase(std::remove_if(messages.begin(), messages.end(),
                                  [&](const auto& m) {
                                    const bool bad = m.second > fmt->second.size;
                                    if (bad && first == 0) first = m.first - 2 - kMessageHeaderSize;
                                    return bad;
                                  }),
                   messages.end());
    if (messages.size() != before) {
      ++f.skip_count_;
      if (f.skips_.size() < kSkipsListed)
        f.skips_.push_back("byte " + std::to_string(first) + ": " +
                           std::to_string(before - messages.size()) + " data messages of '" +
                           sub->second.topic + "' longer than its format (" +
                           std::to_string(fmt->second.size) + " bytes) dropped");
    }
  }
  return f;
}

std::string UlogFile::why_not_valid(std::size_t q) const {
  const std::string& b = bytes_;
  const std::size_t size = load<std::uint16_t>(b.data() + q);
  const char type = b[q + 2];
  const char* p = b.data() + q + kMessageHeaderSize;
  const std::string what =
      "'" + std::string(1, std::isprint(static_cast<unsigned char>(type)) ? type : '?') +
      "' message (type code " + std::to_string(static_cast<unsigned char>(type)) + ", " +
      std::to_string(size) + " bytes)";
  if (message_length(q, true) > 0)
    return what + " followed by no valid message header at byte " +
           std::to_string(q + kMessageHeaderSize + size) +
           " (its size, or what follows, is damaged)";
  if (std::string_view("FIPMQADORLCS").find(type) == std::string_view::npos)
    return "unknown message type (code " + std::to_string(static_cast<unsigned char>(type)) +
           "); the file is damaged here";
  if (type == 'D' && size >= 2) {
    const auto id = load<std::uint16_t>(p);
    const auto it = subscriptions_.find(id);
    if (it == subscriptions_.end())
      return "data for message id " + std::to_string(id) + " before any subscription ('A') to it";
    if (const auto fmt = formats_.find(it->second.topic); fmt != formats_.end())
      return "data message of '" + it->second.topic + "': " + std::to_string(size - 2) +
             " bytes, but its format defines " + std::to_string(fmt->second.size) +
             (fmt->second.logged_size < fmt->second.size
                  ? " (" + std::to_string(fmt->second.logged_size) + " without its end padding)"
                  : std::string());
  }
  if (type == 'A' && size >= 4)
    return "subscription ('A') that is not printable text or redefines message id " +
           std::to_string(load<std::uint16_t>(p + 1));
  return what + " not well formed";
}

std::string UlogFile::damage() const {
  std::string out;
  if (!truncation_.empty()) out += "; the file is truncated or damaged: " + truncation_;
  if (subscriptions_.empty())
    out += "; the file holds no subscription ('A') or data message after its " +
           std::to_string(format_texts_.size()) + " formats (" + std::to_string(bytes_.size()) +
           " bytes): it looks truncated after its definitions";
  out += skipped_damage_clause(skip_count_, skipped_bytes_, skips_);
  std::size_t orphans = 0;
  for (const auto& [id, sub] : subscriptions_)
    if (!formats_.count(sub.topic) && !damaged_formats_.count(sub.topic)) ++orphans;
  if (orphans > 0)
    out += "; " + std::to_string(orphans) + " subscriptions ('A') to a topic with no format ('F')";
  if (!damaged_formats_.empty()) {
    out += "; " + std::to_string(damaged_formats_.size()) + " formats ('F') unreadable:";
    std::size_t listed = 0;
    for (const auto& [name, why] : damaged_formats_) {
      if (++listed > 3) {
        out += " ...";
        break;
      }
      out += " '" + name + "' (" + why + ")";
    }
  }
  return out;
}

std::map<int, std::size_t> UlogFile::instances(const std::string& topic) const {
  std::map<int, std::size_t> out;
  for (const auto& [id, sub] : subscriptions_)
    if (sub.topic == topic)
      if (const auto d = data_.find(id); d != data_.end() && !d->second.empty())
        out[sub.multi_id] += d->second.size();
  return out;
}

const UlogFile::Field* UlogFile::find_field(const Format& f, const std::string& name,
                                            std::size_t& element) const {
  std::string base = name;
  element = 0;
  if (const std::size_t br = name.find('['); br != std::string::npos && name.back() == ']') {
    base = name.substr(0, br);
    try {
      element = std::stoul(name.substr(br + 1, name.size() - br - 2));
    } catch (const std::exception&) {
      return nullptr;
    }
  }
  for (const Field& field : f.fields)
    if (field.name == base && element < field.count && basic_types().count(field.type))
      return &field;
  return nullptr;
}

bool UlogFile::has_field(const std::string& topic, const std::string& field) const {
  const auto it = formats_.find(topic);
  std::size_t element = 0;
  return it != formats_.end() && find_field(it->second, field, element) != nullptr;
}

template <class Visit>
void UlogFile::for_each_message(const std::string& topic, int multi_id,
                                const std::vector<std::string>& fields, Visit visit) const {
  const auto fmt = formats_.find(topic);
  if (fmt == formats_.end()) {
    if (const auto d = damaged_formats_.find(topic); d != damaged_formats_.end())
      throw std::runtime_error(where_ + ": the format of topic '" + topic +
                               "' is damaged, its data cannot be read: " + d->second);
    throw std::runtime_error(where_ + ": no topic '" + topic + "'" + damage());
  }
  std::vector<std::pair<const Field*, std::size_t>> resolved;
  for (const std::string& name : fields) {
    std::size_t element = 0;
    const Field* field = find_field(fmt->second, name, element);
    if (field == nullptr)
      throw std::runtime_error(where_ + ": topic '" + topic + "' has no numeric field '" + name +
                               "' in this log's format");
    resolved.emplace_back(field, element);
  }
  std::vector<std::size_t> at(resolved.size());
  for (const auto& [id, sub] : subscriptions_) {
    if (sub.topic != topic || sub.multi_id != multi_id) continue;
    const auto d = data_.find(id);
    if (d == data_.end()) continue;
    for (const auto& [offset, size] : d->second) {
      for (std::size_t i = 0; i < resolved.size(); ++i) {
        const auto& [field, element] = resolved[i];
        const std::size_t in_message = field->offset + element * field->element_size;
        if (in_message + field->element_size > size)
          throw std::runtime_error(where_ + ": byte " + std::to_string(offset) +
                                   ", data message of '" + topic + "': " + std::to_string(size) +
                                   " bytes, too short for field '" + field->name + "' at offset " +
                                   std::to_string(in_message));
        at[i] = offset + in_message;
      }
      visit(at, resolved);
    }
  }
}

std::vector<std::vector<double>> UlogFile::read(const std::string& topic, int multi_id,
                                                const std::vector<std::string>& fields) const {
  std::vector<std::vector<double>> rows;
  for_each_message(topic, multi_id, fields, [&](const auto& at, const auto& resolved) {
    std::vector<double>& row = rows.emplace_back();
    for (std::size_t i = 0; i < at.size(); ++i)
      row.push_back(decode(resolved[i].first->type, bytes_.data() + at[i]));
  });
  return rows;
}

std::vector<std::size_t> UlogFile::message_offsets(const std::string& topic, int multi_id) const {
  // data_ keeps each message's payload, after its header (3 bytes) and its msg_id (2 bytes).
  constexpr std::size_t kBeforePayload = 3 + 2;
  std::vector<std::size_t> offsets;
  for (const auto& [id, sub] : subscriptions_) {
    if (sub.topic != topic || sub.multi_id != multi_id) continue;
    if (const auto d = data_.find(id); d != data_.end())
      for (const auto& [offset, size] : d->second) offsets.push_back(offset - kBeforePayload);
  }
  return offsets;
}

std::vector<std::size_t> UlogFile::field_offsets(const std::string& topic, int multi_id,
                                                 const std::string& field) const {
  std::vector<std::size_t> offsets;
  for_each_message(topic, multi_id, {field},
                   [&](const auto& at, const auto&) { offsets.push_back(at[0]); });
  return offsets;
}

std::string UlogFile::topics_summary() const {
  std::map<std::string, std::size_t> counts;
  for (const auto& [id, sub] : subscriptions_)
    if (const auto d = data_.find(id); d != data_.end()) counts[sub.topic] += d->second.size();
  std::string out;
  for (const auto& [topic, n] : counts)
    out += (out.empty() ? "" : ", ") + topic + " (" + std::to_string(n) + ")";
  return out;
}

}  // namespace insid::importers
