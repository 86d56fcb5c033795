#pragma once
// GpiodLines: valve lines on Linux GPIO chips through libgpiod 1.6 (v1 API,
// the character device /dev/gpiochipN). Each line is requested once, as an
// output at its inactive level, and held until the object is destroyed: one
// long-lived request per line, so nothing else can drive it meanwhile, and a
// line reverts (to whatever its chip driver does with a free line) when its
// request is closed. Active-low is passed to the kernel with the request
// (GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW), so "active" always means "valve open".
//
// A line is named either by chip and offset (the chip by name "gpiochip0",
// path "/dev/gpiochip0", label or number, as gpiod_chip_open_lookup takes it)
// or by its line name (gpiod_line_find searches every chip).
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hw/valve_lines.hpp"

struct gpiod_chip;
struct gpiod_line;

namespace collide::hw {

struct GpiodLineSpec {
  std::string chip;                ///< chip name/path/label/number; empty when found by name
  std::optional<unsigned> offset;  ///< line offset on `chip`
  std::string name;                ///< line name (gpiod_line_find), when no offset
  std::string text() const;        ///< as written in the profile
};

/// Parses one entry of valves.lines given as a string: "NAME" (a line name)
/// or "CHIP:OFFSET" ("gpiochip1:17"). False if a "CHIP:" prefix has a bad offset.
bool parseGpiodLineSpec(const std::string& text, GpiodLineSpec& out);

class GpiodLines final : public ValveLines {
 public:
  /// Opens the chips and requests every line as an output, inactive.
  /// `consumer` is the name other programs see (gpioinfo). Errors name the
  /// chip or line and say what to do (missing chip, no such line, line in
  /// use by another program, no permission). Nothing stays requested after
  /// an error.
  static Result<std::unique_ptr<GpiodLines>> open(const std::vector<GpiodLineSpec>& specs,
                                                  bool active_low, const std::string& consumer);
  ~GpiodLines() override;

  int count() const override { return static_cast<int>(lines_.size()); }
  std::string describe(int line) const override;
  Status set(int line, bool active) override;
  bool setAllInactiveFromSignal() noexcept override;
  std::optional<std::string> gone() const override;

 private:
  GpiodLines() = default;
  void releaseAll();

  struct Line {
    gpiod_line* line = nullptr;
    gpiod_chip* found_chip = nullptr;  // chip opened by gpiod_line_find (closed with the line)
    std::string text;
  };
  std::vector<gpiod_chip*> chips_;  // chips opened by lookup, shared by their lines
  std::vector<Line> lines_;
  // The first set() that found the chip gone: line << 32 | errno (0: none).
  std::atomic<std::int64_t> gone_{0};
};

}  // namespace collide::hw
