#pragma once
// Small helpers for user messages inside hw (not part of hw's public API).
#include <string>

#include "analysis/result.hpp"

namespace collide::hw {

/// A number as a person would write it: shortest form, up to 6 significant digits.
std::string num(double v);

/// `s` unchanged if ok or its message already names `label`; else the message
/// prefixed with "<label>: ".
Status prefixed(const std::string& label, Status s);

}  // namespace collide::hw
