#pragma once
// Profile settings as plain values with their source line, so every layer can
// read its part of a rig profile with messages that point at the file, line
// and field (`config/sim.toml:23: camera.fps = -5: must be > 0`) without
// seeing the TOML library (only rig_profile.cpp parses TOML). Later backends
// (aravis, v4l2, gpiod, modbus) read their own keys from their device's table
// through a SettingsReader, which also reports keys nobody read (typos).
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include "analysis/result.hpp"

namespace collide::hw {

/// One value as written in a profile.
struct SettingValue {
  using Value = std::variant<bool, std::int64_t, double, std::string, std::vector<double>,
                             std::vector<std::string>>;
  Value value;
  int line = 0;  ///< 1-based line in the source; 0 if not from a file

  /// The value as TOML would write it: 5, -2.5, true, "sim", [1, 2].
  std::string text() const;
};

/// One table of a profile ([camera], [[launcher]] number 2, ...). Nested
/// tables are flattened with dots: [camera.fault] drop_every -> "fault.drop_every".
struct SettingsTable {
  std::string name;    ///< as users write it: "camera", "launcher[2]"
  std::string source;  ///< file name for messages, e.g. "config/sim.toml"
  int line = 0;        ///< line of the table's header (0: not in the file)
  std::map<std::string, SettingValue> values;

  bool has(const std::string& key) const { return values.count(key) != 0; }
};

/// Bounds for a number; each one optional. Failing a bound gives "must be > 0" etc.
struct Bounds {
  std::optional<double> gt = std::nullopt;
  std::optional<double> ge = std::nullopt;
  std::optional<double> lt = std::nullopt;
  std::optional<double> le = std::nullopt;
};

/// Reads typed values out of one table. Every accessor returns the value, the
/// fallback when the key is absent and a fallback was given, or an Error
/// "<source>:<line>: <table>.<key> = <value>: <what is wrong>" (a missing
/// required key points at the table's header line). Remembers which keys were
/// read. Not thread-safe; use from one thread.
class SettingsReader {
 public:
  explicit SettingsReader(const SettingsTable& table) : table_(&table) {}

  Result<double> number(const std::string& key, std::optional<double> fallback = std::nullopt,
                        Bounds bounds = {});
  /// Refuses non-whole numbers.
  Result<std::int64_t> integer(const std::string& key,
                               std::optional<std::int64_t> fallback = std::nullopt,
                               Bounds bounds = {});
  Result<bool> boolean(const std::string& key, std::optional<bool> fallback = std::nullopt);
  /// `choices` non-empty: the value must be one of them (the message lists them).
  Result<std::string> text(const std::string& key,
                           std::optional<std::string> fallback = std::nullopt,
                           const std::vector<std::string>& choices = {});
  /// An array of exactly `count` numbers (count 0: any length), each within `bounds`.
  Result<std::vector<double>> numbers(const std::string& key, std::size_t count,
                                      std::optional<std::vector<double>> fallback = std::nullopt,
                                      Bounds bounds = {});
  /// A number, or an array of `count` numbers; a single number is repeated.
  Result<std::vector<double>> numberOrNumbers(const std::string& key, std::size_t count,
                                              std::optional<double> fallback = std::nullopt,
                                              Bounds bounds = {});

  /// "<source>:<line>: <table>.<key> = <value>: <why>" (or ": <table>.<key>: <why>"
  /// when the key is absent).
  Error invalid(const std::string& key, const std::string& why) const;
  /// "<source>:<line>: <table>.<key>" — where a key is (or would be).
  std::string where(const std::string& key) const;

  /// Marks `key` as read without reading it (keys another layer handles).
  void markRead(const std::string& key) { read_.insert(key); }
  /// Ok if every key of the table was read; else an Error naming the first
  /// unread key as unknown to `reader` (e.g. "the sim camera backend").
  Status finish(const std::string& reader) const;

  const SettingsTable& table() const { return *table_; }

 private:
  const SettingValue* find(const std::string& key);
  Error missing(const std::string& key) const;
  Status checkBounds(const std::string& key, double v, const Bounds& b) const;

  const SettingsTable* table_;
  std::set<std::string> read_;
};

}  // namespace collide::hw
