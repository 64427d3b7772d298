// PX4 ULog files (the PX4 developer guide's "ULog File Format"), read generically: the file's
// own format messages ('F') define every topic's fields, so layouts from any PX4 version are
// read by name; subscriptions ('A') map message ids to topics and instances (multi_id); data
// messages ('D') are kept as byte ranges and decoded on request. Dropouts ('O') are summed,
// appended data (flag bits 'B', DATA_APPENDED) is followed, and a log that ends inside a
// message (the logger stopped) keeps everything before that message and says so.
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
  /// Parses the whole file. Throws std::runtime_error naming `where`, the byte offset, the
  /// message and what was expected (bad magic, an unknown field type, a data message longer than
  /// its format, a subscription to an undefined format, ...).
  static UlogFile parse(std::string bytes, const std::string& where);
  /// Reads the file (core/file_read.h: its magic checked before the rest is read) and parses it.
  static UlogFile read(const std::string& path);

  /// Instances (multi_id) of a topic that have data messages, with their counts.
  std::map<int, std::size_t> instances(const std::string& topic) const;
  /// True when the topic's format has this field ("gyro_rad" or an element "gyro_rad[2]").
  bool has_field(const std::string& topic, const std::string& field) const;
  /// Every data message of topic/instance, the named fields as doubles (array elements as
  /// "name[i]"), in file order. Throws naming a missing field or a message too short for it.
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
  /// Non-empty when the file ends inside a message: what was ignored.
  const std::string& truncation() const { return truncation_; }
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
  };
  struct Subscription {
    std::string topic;
    int multi_id = 0;
  };
  std::size_t format_size(const std::string& name, int depth) const;
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
  std::map<std::string, Format> formats_;
  std::map<std::uint16_t, Subscription> subscriptions_;
  std::map<std::uint16_t, std::vector<std::pair<std::size_t, std::size_t>>> data_;  // offset, size
  double dropouts_ms_ = 0.0;
  std::size_t dropout_count_ = 0;
  std::string truncation_;
};

}  // namespace insid::importers
