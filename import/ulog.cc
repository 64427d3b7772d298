#include "import/ulog.h"
#include "core/file_read.h"

#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace insid::importers {
namespace {

constexpr unsigned char kMagic[7] = {'U', 'L', 'o', 'g', 0x01, 0x12, 0x35};
constexpr std::size_t kHeaderSize = 16;
constexpr std::size_t kMessageHeaderSize = 3;  // uint16 size, uint8 type

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

std::size_t UlogFile::format_size(const std::string& name, int depth) const {
  if (depth > 16) throw std::runtime_error(where_ + ": format '" + name + "' nests itself");
  const auto it = formats_.find(name);
  if (it == formats_.end()) return 0;
  return it->second.size;
}

UlogFile UlogFile::parse(std::string bytes, const std::string& where) {
  UlogFile f;
  f.where_ = where;
  f.bytes_ = std::move(bytes);
  const std::string& b = f.bytes_;
  if (b.size() < kHeaderSize || std::memcmp(b.data(), kMagic, sizeof kMagic) != 0)
    throw std::runtime_error(where +
                             ": byte 0: not a ULog file (expected the magic 'ULog' 01 12 35)");
  f.version_ = static_cast<unsigned char>(b[7]);
  if (f.version_ > 1)
    throw std::runtime_error(where + ": byte 7: ULog version " + std::to_string(f.version_) +
                             " is newer than the version 1 insid reads");
  f.start_us_ = load<std::uint64_t>(b.data() + 8);

  // Formats may refer to formats defined later: collect the texts, resolve after the pass.
  std::vector<std::pair<std::string, std::size_t>> format_texts;  // text, byte offset
  std::vector<std::uint64_t> appended;
  std::size_t pos = kHeaderSize;
  bool first_message = true;
  while (pos < b.size()) {
    if (!appended.empty() && pos > appended.front()) appended.erase(appended.begin());
    if (b.size() - pos < kMessageHeaderSize) {
      f.truncation_ = "the file ends inside a message header at byte " + std::to_string(pos);
      break;
    }
    const std::size_t size = load<std::uint16_t>(b.data() + pos);
    const char type = b[pos + 2];
    const std::size_t body = pos + kMessageHeaderSize;
    if (body + size > b.size()) {
      f.truncation_ = "the file ends inside a '" + std::string(1, type) + "' message at byte " +
                      std::to_string(pos) + " (" + std::to_string(b.size() - pos) +
                      " bytes ignored; the logger stopped mid-write)";
      break;
    }
    // Appended data: a message that would run past the next appended offset is cut there.
    if (!appended.empty() && body + size > appended.front() && pos < appended.front()) {
      pos = static_cast<std::size_t>(appended.front());
      appended.erase(appended.begin());
      continue;
    }
    const std::string at =
        where + ": byte " + std::to_string(pos) + ", '" + std::string(1, type) + "' message";
    const char* p = b.data() + body;
    switch (type) {
      case 'B': {
        if (!first_message) throw std::runtime_error(at + ": flag bits must be the first message");
        if (size < 40)
          throw std::runtime_error(at + ": " + std::to_string(size) + " bytes, expected 40");
        const auto incompat = static_cast<unsigned char>(p[8]);
        if ((incompat & ~1u) != 0 || std::memcmp(p + 9, "\0\0\0\0\0\0\0", 7) != 0)
          throw std::runtime_error(at + ": incompatible flags set that insid does not know");
        if (incompat & 1u)
          for (int k = 0; k < 3; ++k)
            if (const auto off = load<std::uint64_t>(p + 16 + 8 * k); off > 0)
              appended.push_back(off);
        break;
      }
      case 'F':
        format_texts.emplace_back(std::string(p, size), pos);
        break;
      case 'A': {
        if (size < 4)
          throw std::runtime_error(at + ": " + std::to_string(size) +
                                   " bytes, expected at least 4");
        Subscription s;
        s.multi_id = static_cast<unsigned char>(p[0]);
        const auto id = load<std::uint16_t>(p + 1);
        s.topic.assign(p + 3, size - 3);
        f.subscriptions_[id] = s;
        break;
      }
      case 'D': {
        if (size < 2)
          throw std::runtime_error(at + ": " + std::to_string(size) +
                                   " bytes, expected at least 2");
        const auto id = load<std::uint16_t>(p);
        if (!f.subscriptions_.count(id))
          throw std::runtime_error(at + ": data for message id " + std::to_string(id) +
                                   " before any subscription ('A') to it");
        f.data_[id].emplace_back(body + 2, size - 2);
        break;
      }
      case 'O':
        if (size >= 2) {
          f.dropouts_ms_ += load<std::uint16_t>(p);
          ++f.dropout_count_;
        }
        break;
      case 'I':
      case 'M':
      case 'P':
      case 'Q':
      case 'L':
      case 'C':
      case 'S':
      case 'R':
        break;  // information, parameters, log text, sync, unsubscription: not needed here
      default:
        throw std::runtime_error(at + ": unknown message type (code " +
                                 std::to_string(static_cast<unsigned char>(type)) +
                                 "); the file is damaged here");
    }
    first_message = false;
    pos = body + size;
  }

  // Formats: "name:type field;type[n] field;..."
  for (const auto& [text, offset] : format_texts) {
    const std::string at =
        where + ": byte " + std::to_string(offset) + ", format '" + text.substr(0, 60) + "'";
    const std::size_t colon = text.find(':');
    if (colon == std::string::npos || colon == 0)
      throw std::runtime_error(at + ": expected 'name:fields'");
    Format fmt;
    std::size_t start = colon + 1;
    while (start < text.size()) {
      std::size_t end = text.find(';', start);
      if (end == std::string::npos) end = text.size();
      const std::string item = text.substr(start, end - start);
      start = end + 1;
      if (item.empty()) continue;
      const std::size_t space = item.find(' ');
      if (space == std::string::npos)
        throw std::runtime_error(at + ": field '" + item + "' is not 'type name'");
      Field field;
      field.type = item.substr(0, space);
      field.name = item.substr(space + 1);
      if (const std::size_t br = field.type.find('['); br != std::string::npos) {
        const std::size_t close = field.type.find(']', br);
        if (close == std::string::npos)
          throw std::runtime_error(at + ": field '" + item + "': unclosed '['");
        try {
          field.count = std::stoul(field.type.substr(br + 1, close - br - 1));
        } catch (const std::exception&) {
          throw std::runtime_error(at + ": field '" + item + "': array size is not a number");
        }
        if (field.count == 0 || field.count > 65535)
          throw std::runtime_error(at + ": field '" + item + "': array size out of range");
        field.type = field.type.substr(0, br);
      }
      fmt.fields.push_back(field);
    }
    f.formats_[text.substr(0, colon)] = fmt;
  }
  // Sizes and offsets (nested formats resolved; a cycle or an unknown type is an error).
  for (int pass = 0; pass < 17; ++pass) {
    bool changed = false;
    for (auto& [name, fmt] : f.formats_) {
      std::size_t offset = 0;
      bool complete = true;
      for (Field& field : fmt.fields) {
        const auto basic = basic_types().find(field.type);
        std::size_t element = basic != basic_types().end() ? basic->second : 0;
        if (element == 0) {
          const auto nested = f.formats_.find(field.type);
          if (nested == f.formats_.end())
            throw std::runtime_error(where + ": format '" + name + "', field '" + field.name +
                                     "': unknown type '" + field.type + "'");
          element = nested->second.size;
          if (element == 0) complete = false;
        }
        field.offset = offset;
        field.element_size = element;
        offset += element * field.count;
      }
      if (complete && fmt.size != offset) {
        fmt.size = offset;
        changed = true;
      }
    }
    if (!changed) break;
  }
  for (const auto& [id, sub] : f.subscriptions_) {
    const auto it = f.formats_.find(sub.topic);
    if (it == f.formats_.end())
      throw std::runtime_error(where + ": subscription to '" + sub.topic + "' (id " +
                               std::to_string(id) + ") has no format ('F') message");
    if (it->second.size == 0)
      throw std::runtime_error(where + ": format '" + sub.topic + "' nests itself");
    if (const auto d = f.data_.find(id); d != f.data_.end())
      for (const auto& [offset, size] : d->second)
        if (size > it->second.size)
          throw std::runtime_error(
              where + ": byte " + std::to_string(offset - 2 - kMessageHeaderSize) +
              ", data message of '" + sub.topic + "': " + std::to_string(size) +
              " bytes, but its format defines " + std::to_string(it->second.size));
  }
  return f;
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
  if (fmt == formats_.end()) throw std::runtime_error(where_ + ": no topic '" + topic + "'");
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
