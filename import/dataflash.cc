#include "import/dataflash.h"
#include "import/log_damage.h"

#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

namespace insid::importers {
namespace {

constexpr unsigned char kHead1 = 0xA3, kHead2 = 0x95;
constexpr std::uint8_t kFmtId = 128;
constexpr std::size_t kFmtLength = 89;  // 3 + type 1 + length 1 + name 4 + format 16 + labels 64

// Bytes of a type letter (ArduPilot's LogStructure.h); 0 for a letter it does not define.
std::size_t letter_size(char c) {
  switch (c) {
    case 'b':
    case 'B':
    case 'M':
      return 1;
    case 'h':
    case 'H':
    case 'c':
    case 'C':
      return 2;
    case 'i':
    case 'I':
    case 'f':
    case 'e':
    case 'E':
    case 'L':
    case 'n':
      return 4;
    case 'd':
    case 'q':
    case 'Q':
      return 8;
    case 'N':
      return 16;
    case 'Z':
    case 'a':
      return 64;
    default:
      return 0;
  }
}

bool is_number(char c) { return c != 'n' && c != 'N' && c != 'Z' && c != 'a'; }

template <class T>
T load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);  // DataFlash is little-endian, as is every host insid builds on
  return v;
}

double decode(char type, const char* p) {
  switch (type) {
    case 'b':
      return load<std::int8_t>(p);
    case 'B':
    case 'M':
      return load<std::uint8_t>(p);
    case 'h':
      return load<std::int16_t>(p);
    case 'H':
      return load<std::uint16_t>(p);
    case 'i':
      return load<std::int32_t>(p);
    case 'I':
      return load<std::uint32_t>(p);
    case 'f':
      return static_cast<double>(load<float>(p));
    case 'd':
      return load<double>(p);
    case 'q':
      return static_cast<double>(load<std::int64_t>(p));
    case 'Q':
      return static_cast<double>(load<std::uint64_t>(p));
    case 'c':
      return load<std::int16_t>(p) * 0.01;
    case 'C':
      return load<std::uint16_t>(p) * 0.01;
    case 'e':
      return load<std::int32_t>(p) * 0.01;
    case 'E':
      return load<std::uint32_t>(p) * 0.01;
    case 'L':
      return load<std::int32_t>(p) * 1e-7;
    default:
      throw std::logic_error("DataFlash decode: not a number letter");
  }
}

// A fixed char[n] field up to its first NUL.
std::string fixed_string(const char* p, std::size_t n) {
  std::size_t len = 0;
  while (len < n && p[len] != '\0') ++len;
  return std::string(p, len);
}

bool printable(const std::string& s) {
  for (const char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}

std::string in_quotes(const std::string& s) {
  if (printable(s)) return "'" + s + "'";
  std::ostringstream out;
  out << "(not printable:";
  for (const char c : s) out << ' ' << static_cast<int>(static_cast<unsigned char>(c));
  out << ')';
  return out.str();
}

}  // namespace

DataFlashFile DataFlashFile::parse(std::string bytes, const std::string& where) {
  DataFlashFile f;
  f.where_ = where;
  f.bytes_ = std::move(bytes);
  const std::string& b = f.bytes_;
  const std::size_t size = b.size();
  // FMT's own layout is fixed by the format (ArduPilot writes it as the first record).
  Format fmt;
  fmt.id = kFmtId;
  fmt.name = "FMT";
  fmt.letters = "BBnNZ";
  fmt.length = kFmtLength;
  fmt.fields = {{'B', "Type", 3},
                {'B', "Length", 4},
                {'n', "Name", 5},
                {'N', "Format", 9},
                {'Z', "Columns", 25}};
  f.formats_[kFmtId] = fmt;
  std::map<std::string, std::uint8_t> ids = {{"FMT", kFmtId}};

  const auto stop = [&](std::size_t pos, const std::string& why) {
    f.truncation_ = where + ": byte " + std::to_string(pos) + ": " + why + "; the " +
                    std::to_string(size - pos) +
                    " bytes from there are ignored (the records before it are kept)";
  };
  // A header at q that starts a record of a known message which fits in the file and is
  // followed by another such header or the file's end: where reading resumes after damage
  // (two headers in a row, so that 0xA3 0x95 inside a damaged record's data rarely passes).
  const auto record_at = [&](std::size_t q) -> std::size_t {  // its length, 0 if none
    if (size - q < 3 || static_cast<unsigned char>(b[q]) != kHead1 ||
        static_cast<unsigned char>(b[q + 1]) != kHead2)
      return 0;
    const auto known = f.formats_.find(static_cast<std::uint8_t>(b[q + 2]));
    if (known == f.formats_.end() || known->second.length < 3 || size - q < known->second.length)
      return 0;
    return known->second.length;
  };
  const auto next_valid = [&](std::size_t from) -> std::size_t {
    for (std::size_t q = from; q + 3 <= size; ++q) {
      const std::size_t n = record_at(q);
      if (n > 0 && (q + n == size || record_at(q + n) > 0)) return q;
    }
    return size;
  };
  // Damage inside the log: skipped to the next valid record (ArduPilot's own log tools
  // resynchronise on the next header), counted and named; only the end of the file stops.
  const auto skip = [&](std::size_t at, const std::string& why) -> std::size_t {
    const std::size_t resume = next_valid(at + 1);
    if (resume == size) {
      stop(at, why);
      return size;
    }
    f.skipped_bytes_ += resume - at;
    if (f.skips_.size() < 20)
      f.skips_.push_back("byte " + std::to_string(at) + ": " + why + "; " +
                         std::to_string(resume - at) +
                         " bytes skipped to the next record at byte " + std::to_string(resume));
    ++f.skip_count_;
    return resume;
  };
  std::size_t pos = 0;
  while (pos < size) {
    if (size - pos < 3) {
      stop(pos, "the file ends inside a record header");
      break;
    }
    const auto c0 = static_cast<unsigned char>(b[pos]), c1 = static_cast<unsigned char>(b[pos + 1]);
    const auto id = static_cast<std::uint8_t>(b[pos + 2]);
    if (c0 != kHead1 || c1 != kHead2) {
      if (pos == 0)
        throw std::runtime_error(where +
                                 ": byte 0: not an ArduPilot DataFlash log (expected "
                                 "the record header 0xA3 0x95)");
      pos = skip(pos, "no record header (expected 0xA3 0x95)");
      continue;
    }
    const auto it = f.formats_.find(id);
    if (it == f.formats_.end()) {
      pos = skip(pos, "message id " + std::to_string(id) + " has no FMT record before it");
      continue;
    }
    Format& format = it->second;
    if (size - pos < format.length) {
      stop(pos, "the file ends inside a record of " + format.name + " (" +
                    std::to_string(format.length) + " bytes, " + std::to_string(size - pos) +
                    " left)");
      break;
    }
    if (id == kFmtId) {
      // A FMT record: check it entirely before it defines anything.
      const std::string context = where + ": byte " + std::to_string(pos) + ": FMT record";
      const auto type = static_cast<std::uint8_t>(b[pos + 3]);
      const auto length = static_cast<std::size_t>(static_cast<unsigned char>(b[pos + 4]));
      const std::string name = fixed_string(&b[pos + 5], 4);
      const std::string letters = fixed_string(&b[pos + 9], 16);
      const std::string labels = fixed_string(&b[pos + 25], 64);
      const std::string about = context + " for message id " + std::to_string(type);
      if (name.empty() || !printable(name))
        throw std::runtime_error(about + ", field Name: " + in_quotes(name) +
                                 " is not a message name (expected 1-4 printable characters)");
      const std::string named = about + " (" + name + ")";
      if (!printable(letters) || !printable(labels))
        throw std::runtime_error(named + ": field " + (printable(letters) ? "Columns" : "Format") +
                                 " is not printable text");
      Format def;
      def.id = type;
      def.name = name;
      def.letters = letters;
      def.length = length;
      std::vector<std::string> names;
      if (!labels.empty()) {
        std::size_t s = 0;
        for (;;) {
          const std::size_t e = labels.find(',', s);
          names.push_back(labels.substr(s, e == std::string::npos ? std::string::npos : e - s));
          if (e == std::string::npos) break;
          s = e + 1;
        }
      }
      if (names.size() != letters.size())
        throw std::runtime_error(named + ": field Format " + in_quotes(letters) + " has " +
                                 std::to_string(letters.size()) +
                                 " type letters but field Columns " + in_quotes(labels) +
                                 " names " + std::to_string(names.size()) +
                                 " fields (expected one name per letter)");
      std::size_t offset = 3;
      for (std::size_t i = 0; i < letters.size(); ++i) {
        const std::size_t n = letter_size(letters[i]);
        if (n == 0)
          throw std::runtime_error(named + ": field Format " + in_quotes(letters) +
                                   ": unknown type letter '" + std::string(1, letters[i]) +
                                   "' for field " + names[i] +
                                   " (expected one of b B h H i I f d q Q n N Z c C e E L M a)");
        def.fields.push_back({letters[i], names[i], offset});
        offset += n;
      }
      if (offset != length)
        throw std::runtime_error(named + ": field Length " + std::to_string(length) +
                                 " disagrees with field Format " + in_quotes(letters) +
                                 " (3 header "
                                 "bytes + " +
                                 std::to_string(offset - 3) + " = " + std::to_string(offset) +
                                 " expected)");
      const auto known = f.formats_.find(type);
      if (known != f.formats_.end()) {
        if (known->second.name != name || known->second.letters != letters ||
            known->second.length != length)
          throw std::runtime_error(named + ": redefines message id " + std::to_string(type) +
                                   " (defined before as " + known->second.name + ", " +
                                   in_quotes(known->second.letters) + ", " +
                                   std::to_string(known->second.length) + " bytes)");
      } else {
        if (ids.count(name))
          throw std::runtime_error(named + ": the name " + name + " is already message id " +
                                   std::to_string(ids[name]));
        ids[name] = type;
        f.formats_[type] = def;
      }
    }
    f.formats_.at(id).records.push_back(pos);
    pos += f.formats_.at(id).length;
  }
  return f;
}

const DataFlashFile::Format& DataFlashFile::format(const std::string& name) const {
  for (const auto& [id, f] : formats_)
    if (f.name == name) return f;
  throw std::runtime_error(where_ + ": no FMT record defines message " + name +
                           "; messages with records: " + messages_summary() + damage());
}

std::string DataFlashFile::damage() const {
  std::string out;
  if (!truncation_.empty()) out += "; the file is truncated or damaged: " + truncation_;
  out += skipped_damage_clause(skip_count_, skipped_bytes_, skips_);
  std::size_t records = 0;
  for (const auto& [id, f] : formats_)
    if (id != kFmtId) records += f.records.size();
  if (records == 0)
    out += "; the file holds no record but its " + std::to_string(formats_.size() - 1) +
           " FMT records (" + std::to_string(bytes_.size()) +
           " bytes): it looks truncated after its definitions";
  return out;
}

std::size_t DataFlashFile::count(const std::string& name) const {
  for (const auto& [id, f] : formats_)
    if (f.name == name) return f.records.size();
  return 0;
}

bool DataFlashFile::has_field(const std::string& name, const std::string& field) const {
  for (const auto& [id, f] : formats_)
    if (f.name == name)
      for (const Field& x : f.fields)
        if (x.name == field) return true;
  return false;
}

char DataFlashFile::field_type(const std::string& name, const std::string& field) const {
  for (const auto& [id, f] : formats_)
    if (f.name == name)
      for (const Field& x : f.fields)
        if (x.name == field) return x.type;
  return 0;
}

std::size_t DataFlashFile::field_offset(const std::string& name, const std::string& field) const {
  const Format& f = format(name);
  for (const Field& x : f.fields)
    if (x.name == field) return x.offset;
  throw std::runtime_error(where_ + ": message " + name + " has no field " + field);
}

std::vector<std::vector<double>> DataFlashFile::read(const std::string& name,
                                                     const std::vector<std::string>& fields) const {
  const Format& f = format(name);
  std::vector<const Field*> picked;
  for (const std::string& want : fields) {
    const Field* found = nullptr;
    for (const Field& x : f.fields)
      if (x.name == want) found = &x;
    if (found == nullptr) {
      std::string have;
      for (const Field& x : f.fields) have += (have.empty() ? "" : ",") + x.name;
      throw std::runtime_error(where_ + ": message " + name + " has no field " + want +
                               " (its FMT names " + have + ")");
    }
    if (!is_number(found->type))
      throw std::runtime_error(where_ + ": message " + name + ", field " + want + ": type '" +
                               std::string(1, found->type) + "' is text, not a number");
    picked.push_back(found);
  }
  std::vector<std::vector<double>> rows;
  rows.reserve(f.records.size());
  for (const std::size_t at : f.records) {
    std::vector<double> row;
    row.reserve(picked.size());
    for (const Field* x : picked) row.push_back(decode(x->type, bytes_.data() + at + x->offset));
    rows.push_back(std::move(row));
  }
  return rows;
}

std::vector<std::size_t> DataFlashFile::offsets(const std::string& name) const {
  return format(name).records;
}

std::string DataFlashFile::messages_summary() const {
  std::map<std::string, std::size_t> by_name;
  for (const auto& [id, f] : formats_)
    if (!f.records.empty() && id != kFmtId) by_name[f.name] = f.records.size();
  std::string out;
  for (const auto& [n, c] : by_name)
    out += (out.empty() ? "" : ", ") + n + " (" + std::to_string(c) + ")";
  return out.empty() ? "none" : out;
}

}  // namespace insid::importers
