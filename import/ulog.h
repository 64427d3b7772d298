// PX4 ULog files (the PX4 developer guide's "ULog File Format"), read generically: the file's
// own format messages ('F') define every topic's fields, so layouts from any PX4 version are
// read by name; subscriptions ('A') map message ids to topics and instances (multi_id); data
// messages ('D') are kept as byte ranges and decoded on request. Dropouts ('O') are summed,
// appended data (flag bits 'B', DATA_APPENDED) is followed, and a log that ends inside a
// message (the logger stopped) keeps everything before that message and says so.
// Damage is read past: a message that is not well formed, or not followed by one, is skipped to
// the next well-formed pair of messages (counted and named by byte); a format that cannot be read
// costs only the topics that use it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace insid::importers {

/// The first bytes of every ULog file (PX4 ULog spec: "ULog", 0x01 0x12 0x35).
inline constexpr std::string_view kUlogMagic{"ULog\x01\x12\x35", 7};

class UlogFile {
 public:
  /// Parses the whole file. Throws std::runtime_error naming `where` and the byte offset only
  /// where nothing can be read: a bad magic, a newer version, flag bits that insid does not know.
  /// Damage elsewhere is skipped (skips(), truncation(), damage()).
  static UlogFile parse(std::string bytes, const std::string& where);
  /// Reads the file (base/file_read.h: its magic checked before the rest is read) and parses it.
  static UlogFile read(const std::string& path);

  /// Instances (multi_id) of a topic that have data messages, with their counts.
  std::map<int, std::size_t> instances(const std::string& topic) const;
  /// True when the topic's format has this field ("gyro_rad" or an element "gyro_rad[2]").
  bool has_field(const std::string& topic, const std::string& field) const;
  /// Every data message of topic/instance, the named fields as doubles (array elements as
  /// "name[i]"), in file order. Throws naming a missing field or a message too short for it, a
  /// damaged format (its byte), or a missing topic (with damage()).
  std::vector<std::vector<double>> read(const std::string& topic, int multi_id,
                                        const std::vector<std::string>& fields) const;
  /// The byte offset in the file of `field` in every data message of topic/instance, in the
  /// order read() gives the messages (to name where a value was read). Throws as read() does.
  std::vector<std::size_t> field_offsets(const std::string& topic, int multi_id,
                                         const std::string& field) const;
  /// The byte offset in the file of every data message of topic/instance (where its 3-byte
  /// header, msg_size and msg_type 'D', starts), in the order read() gives the messages.
  std::vector<std::size_t> message_offsets(const std::string& topic, int multi_id) const;

  std::uint64_t start_timestamp_us() const { return start_us_; }
  int version() const { return version_; }
  double dropouts_ms() const { return dropouts_ms_; }
  std::size_t dropouts() const { return dropout_count_; }
  /// Non-empty when the file ends inside a message, or no valid message follows damage: where,
  /// and what was ignored.
  const std::string& truncation() const { return truncation_; }
  /// Damage inside the log that reading skipped, resuming on the next valid message: how many
  /// places, how many bytes, and the first 20 places named ("byte N: why; K bytes skipped ...").
  std::size_t skip_count() const { return skip_count_; }
  std::size_t skipped_bytes() const { return skipped_bytes_; }
  const std::vector<std::string>& skips() const { return skips_; }
  /// Formats ('F') that could not be read, by topic name: "byte N: why".
  const std::map<std::string, std::string>& damaged_formats() const { return damaged_formats_; }
  /// Everything above in one clause for an error message ("; the file is truncated ...; 2
  /// damaged places skipped ..."), empty for an intact file.
  std::string damage() const;
  /// Topics with data, for messages ("sensor_combined (12000), vehicle_gps_position (900)").
  std::string topics_summary() const;

 private:
  struct Field {
    std::string type, name;
    std::size_t count = 1, offset = 0, element_size = 0;
  };
  struct Format {
    std::vector<Field> fields;
    std::size_t size = 0;
    std::size_t logged_size = 0;  ///< size less the trailing "_padding" fields, which PX4 omits
    std::size_t byte = 0;         ///< of its 'F' message
  };
  struct Subscription {
    std::string topic;
    int multi_id = 0;
    std::size_t byte = 0;  ///< of its 'A' message
  };
  /// formats_ and damaged_formats_ from format_texts_.
  void resolve_formats();
  /// The length (header included) of the well-formed message at byte q, 0 if there is none:
  /// a known type whose fields fit its size; when `strict`, also data for a subscribed id as long
  /// as its format, or shorter by trailing padding only, and no subscription that redefines an
  /// id.
  std::size_t message_length(std::size_t q, bool strict) const;
  /// Why the message at byte q was not taken, for the skip's note.
  std::string why_not_valid(std::size_t q) const;
  const Field* find_field(const Format& f, const std::string& name, std::size_t& element) const;
  /// Calls visit(file offset of each field value, field) for every data message of
  /// topic/instance, in order, after checking the message is long enough for every field.
  template <class Visit>
  void for_each_message(const std::string& topic, int multi_id,
                        const std::vector<std::string>& fields, Visit visit) const;

  std::string where_;
  std::string bytes_;
  int version_ = 0;
  std::uint64_t start_us_ = 0;
  std::vector<std::pair<std::string, std::size_t>> format_texts_;  // text, byte offset
  std::size_t resolved_texts_ = 0;
  std::map<std::string, Format> formats_;
  std::map<std::string, std::string> damaged_formats_;
  std::map<std::uint16_t, Subscription> subscriptions_;
  std::map<std::uint16_t, std::vector<std::pair<std::size_t, std::size_t>>> data_;  // offset, size
  double dropouts_ms_ = 0.0;
  std::size_t dropout_count_ = 0;
  std::string truncation_;
  std::size_t skip_count_ = 0, skipped_bytes_ = 0;
  std::vector<std::string> skips_;
};

}  // namespace insid::importers
