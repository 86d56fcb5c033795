#include "hw/gpiod_lines.hpp"

#include <gpiod.h>

#include <cerrno>
#include <cstring>
#include <map>

namespace collide::hw {

std::string GpiodLineSpec::text() const {
  if (offset) return chip + ":" + std::to_string(*offset);
  return name;
}

bool parseGpiodLineSpec(const std::string& text, GpiodLineSpec& out) {
  out = GpiodLineSpec{};
  const auto colon = text.rfind(':');
  if (colon != std::string::npos && colon > 0 && colon + 1 < text.size()) {
    const std::string digits = text.substr(colon + 1);
    if (digits.find_first_not_of("0123456789") == std::string::npos && digits.size() <= 6) {
      out.chip = text.substr(0, colon);
      out.offset = static_cast<unsigned>(std::stoul(digits));
      return true;
    }
  }
  if (text.empty()) return false;
  out.name = text;
  return true;
}

namespace {

std::string errnoText(int err) {
  return std::strerror(err);
}

std::string chipAdvice(const std::string& chip, int err) {
  if (err == EACCES || err == EPERM)
    return "no permission to open GPIO chip \"" + chip +
           "\": add yourself to the collide group and install udev/60-collide.rules (README, "
           "Lab set-up)";
  return "cannot open GPIO chip \"" + chip + "\" (" + errnoText(err) +
         "): check valves.device / valves.lines; `gpiodetect` lists the chips";
}

}  // namespace

Result<std::unique_ptr<GpiodLines>> GpiodLines::open(const std::vector<GpiodLineSpec>& specs,
                                                     bool active_low, const std::string& consumer) {
  std::unique_ptr<GpiodLines> out(new GpiodLines());
  std::map<std::string, gpiod_chip*> by_name;
  const int flags = active_low ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0;
  for (const GpiodLineSpec& spec : specs) {
    Line l;
    l.text = spec.text();
    if (spec.offset) {
      gpiod_chip*& chip = by_name[spec.chip];
      if (!chip) {
        errno = 0;
        chip = gpiod_chip_open_lookup(spec.chip.c_str());
        if (!chip) {
          const int err = errno ? errno : ENOENT;
          by_name.erase(spec.chip);
          return fail(chipAdvice(spec.chip, err));
        }
        out->chips_.push_back(chip);
      }
      const unsigned n = gpiod_chip_num_lines(chip);
      if (*spec.offset >= n)
        return fail("GPIO chip \"" + spec.chip + "\" has lines 0.." + std::to_string(n - 1) +
                    ", not " + std::to_string(*spec.offset) + ": check valves.lines (`gpioinfo " +
                    spec.chip + "` lists them)");
      l.line = gpiod_chip_get_line(chip, *spec.offset);
      if (!l.line) return fail("cannot get line " + l.text + " (" + errnoText(errno) + ")");
      l.text = std::string(gpiod_chip_name(chip)) + ":" + std::to_string(*spec.offset);
    } else {
      errno = 0;
      l.line = gpiod_line_find(spec.name.c_str());
      if (!l.line) {
        if (errno == 0 || errno == ENOENT)
          return fail("no GPIO line is named \"" + spec.name +
                      "\": check valves.lines (`gpioinfo` lists line names; or give "
                      "\"gpiochipN:OFFSET\")");
        return fail("looking for GPIO line \"" + spec.name + "\" failed (" + errnoText(errno) +
                    "): check the permissions on /dev/gpiochip* (README, Lab set-up)");
      }
      l.found_chip = gpiod_line_get_chip(l.line);
      l.text = "\"" + spec.name + "\" (" + gpiod_chip_name(l.found_chip) + ":" +
               std::to_string(gpiod_line_offset(l.line)) + ")";
    }
    // The line starts inactive: the request itself drives it so, with no
    // glitch through the active level.
    if (gpiod_line_request_output_flags(l.line, consumer.c_str(), flags, 0) != 0) {
      const int err = errno;
      std::string why;
      if (err == EBUSY) {
        const char* user = gpiod_line_consumer(l.line);
        why = "GPIO line " + l.text + " is in use" +
              (user && *user ? std::string(" by \"") + user + "\"" : std::string()) +
              ": stop the other program (`gpioinfo` shows who holds it)";
      } else {
        why = "cannot request GPIO line " + l.text + " as an output (" + errnoText(err) + ")";
      }
      if (l.found_chip) gpiod_chip_close(l.found_chip);
      return fail(why);
    }
    out->lines_.push_back(l);
  }
  return out;
}

GpiodLines::~GpiodLines() {
  releaseAll();
}

void GpiodLines::releaseAll() {
  for (Line& l : lines_) {
    if (!l.line) continue;
    // Inactive first: on chips that keep the last value after release, the
    // valve must not stay open.
    gpiod_line_set_value(l.line, 0);
    gpiod_line_release(l.line);
    if (l.found_chip) gpiod_chip_close(l.found_chip);
    l.line = nullptr;
  }
  lines_.clear();
  for (gpiod_chip* c : chips_) gpiod_chip_close(c);
  chips_.clear();
}

std::string GpiodLines::describe(int line) const {
  return "GPIO line " + lines_[static_cast<std::size_t>(line)].text;
}

Status GpiodLines::set(int line, bool active) {
  if (gpiod_line_set_value(lines_[static_cast<std::size_t>(line)].line, active ? 1 : 0) != 0) {
    const int err = errno;
    // The chip was unplugged or its driver unbound: the request is dead, and
    // only requesting the lines again (reopening the bank) can find it.
    if (err == ENODEV || err == ENXIO || err == EIO) {
      std::int64_t none = 0;
      gone_.compare_exchange_strong(none, (static_cast<std::int64_t>(line) << 32) | err);
    }
    return fail("cannot drive " + describe(line) + (active ? " active" : " inactive") + " (" +
                errnoText(err) + ")");
  }
  return Ok{};
}

std::optional<std::string> GpiodLines::gone() const {
  const std::int64_t g = gone_.load();
  if (g == 0) return std::nullopt;
  return "its GPIO chip went away (driving " + describe(static_cast<int>(g >> 32)) + ": " +
         errnoText(static_cast<int>(g & 0xFFFFFFFF)) + ")";
}

bool GpiodLines::setAllInactiveFromSignal() noexcept {
  // gpiod_line_set_value is one ioctl on the line's request descriptor with
  // a stack buffer: no allocation, no lock.
  bool ok = true;
  for (Line& l : lines_)
    if (l.line && gpiod_line_set_value(l.line, 0) != 0) ok = false;
  return ok;
}

}  // namespace collide::hw
