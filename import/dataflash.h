// ArduPilot DataFlash binary logs (.bin), read generically: every record is 0xA3 0x95, a message
// id and the payload; FMT records (id 128) define each message's name, length, field type
// letters and field names, so layouts are read from the file and never assumed. Type letters as
// ArduPilot documents them (libraries/AP_Logger/LogStructure.h): b B h H i I int8/uint8/int16/
// uint16/int32/uint32, f float32, d float64, q Q int64/uint64, n N Z char[4]/[16]/[64],
// c C int16/uint16 x 0.01, e E int32/uint32 x 0.01, L int32 x 1e-7 (latitude/longitude, deg),
// M uint8 (flight mode), a int16[32]. A log that ends inside a record, or whose bytes stop being
// records (no 0xA3 0x95, an id without a FMT), keeps everything before that byte and says so.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace insid::importers {

/// The first bytes of a DataFlash log: a record header (0xA3 0x95).
inline constexpr std::string_view kDataFlashMagic{"\xA3\x95", 2};

class DataFlashFile {
 public:
  /// Parses the whole file. Throws std::runtime_error naming `where`, the byte offset, the record
  /// and what was expected: a file that does not start with a record, a FMT record with an
  /// unknown type letter, a length that disagrees with its letters, more names than letters, or
  /// a FMT that redefines an id with another layout.
  static DataFlashFile parse(std::string bytes, const std::string& where);

  /// Records of the message named `name` (e.g. "IMU2"); 0 when none or not defined.
  std::size_t count(const std::string& name) const;
  bool has_field(const std::string& name, const std::string& field) const;
  /// The FMT type letter of a field (e.g. 'c' for int16 x 0.01), 0 when the message or field is
  /// not defined: for fields whose unit depends on how the autopilot filled them.
  char field_type(const std::string& name, const std::string& field) const;
  /// Every record of `name`, the named fields as doubles scaled by their letter (c C e E x 0.01,
  /// L x 1e-7), in file order. Throws naming an undefined message, a missing field or a field
  /// that is not a number (n N Z a).
  std::vector<std::vector<double>> read(const std::string& name,
                                        const std::vector<std::string>& fields) const;
  /// Where `field` lies in each record of `name`, in bytes from the record's first header byte.
  /// Throws naming an undefined message or field.
  std::size_t field_offset(const std::string& name, const std::string& field) const;
  /// The byte offset in the file of each record of `name`, in the order read() gives them.
  std::vector<std::size_t> offsets(const std::string& name) const;

  /// Non-empty when the records stop before the end of the file: where and why, and how many
  /// bytes were ignored.
  const std::string& truncation() const { return truncation_; }
  /// Damage inside the log that reading skipped, resuming on the next valid record (two
  /// headers in a row): how many places, how many bytes, and the first 20 places named
  /// ("byte N: why; K bytes skipped to the next record at byte M").
  std::size_t skip_count() const { return skip_count_; }
  std::size_t skipped_bytes() const { return skipped_bytes_; }
  const std::vector<std::string>& skips() const { return skips_; }
  /// The above in one clause for an error message ("; the file is truncated ...; 2 damaged
  /// places skipped ..."; a file of FMT records only "looks truncated"), empty when intact.
  std::string damage() const;
  /// Messages with records, for messages ("GPS (1199), IMU (11916), ...").
  std::string messages_summary() const;

 private:
  struct Field {
    char type = 0;
    std::string name;
    std::size_t offset = 0;  ///< from the record's start (after the 3 header bytes: 3 + ...)
  };
  struct Format {
    std::uint8_t id = 0;
    std::string name, letters;
    std::size_t length = 0;  ///< the whole record, header included
    std::vector<Field> fields;
    std::vector<std::size_t> records;  ///< byte offsets of the records
  };
  const Format& format(const std::string& name) const;

  std::string where_;
  std::string bytes_;
  std::map<std::uint8_t, Format> formats_;
  std::string truncation_;
  std::size_t skip_count_ = 0, skipped_bytes_ = 0;
  std::vector<std::string> skips_;
};

}  // namespace insid::importers
