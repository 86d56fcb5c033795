#include "hw/settings.hpp"

#include <cmath>

#include "hw/format.hpp"

namespace collide::hw {

namespace {

std::string quoted(const std::string& s) {
  return "\"" + s + "\"";
}

std::string typeName(const SettingValue::Value& v) {
  switch (v.index()) {
    case 0: return "a boolean";
    case 1: return "an integer";
    case 2: return "a number";
    case 3: return "a string";
    default: return "an array";
  }
}

std::string boundsText(const Bounds& b) {
  std::string s;
  auto add = [&](const char* op, const std::optional<double>& v) {
    if (!v) return;
    s += (s.empty() ? "must be " : " and ") + std::string(op) + " " + num(*v);
  };
  add(">", b.gt);
  add(">=", b.ge);
  add("<", b.lt);
  add("<=", b.le);
  return s;
}

}  // namespace

std::string SettingValue::text() const {
  struct Visitor {
    std::string operator()(bool b) const { return b ? "true" : "false"; }
    std::string operator()(std::int64_t i) const { return std::to_string(i); }
    std::string operator()(double d) const { return num(d); }
    std::string operator()(const std::string& s) const { return quoted(s); }
    std::string operator()(const std::vector<double>& v) const {
      std::string s = "[";
      for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + num(v[i]);
      return s + "]";
    }
    std::string operator()(const std::vector<std::string>& v) const {
      std::string s = "[";
      for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + quoted(v[i]);
      return s + "]";
    }
  };
  return std::visit(Visitor{}, value);
}

std::string SettingsReader::where(const std::string& key) const {
  const auto it = table_->values.find(key);
  const int line = it != table_->values.end() ? it->second.line : table_->line;
  std::string s = table_->source;
  if (line > 0) {
    s.push_back(':');
    s.append(std::to_string(line));
  }
  s.append(": ");
  if (!table_->name.empty()) s.append(table_->name).push_back('.');
  return s.append(key);
}

Error SettingsReader::invalid(const std::string& key, const std::string& why) const {
  const auto it = table_->values.find(key);
  if (it == table_->values.end()) return fail(where(key) + ": " + why);
  return fail(where(key) + " = " + it->second.text() + ": " + why);
}

Error SettingsReader::missing(const std::string& key) const {
  return fail(where(key) + " is missing: add it to [" + table_->name + "]");
}

const SettingValue* SettingsReader::find(const std::string& key) {
  read_.insert(key);
  const auto it = table_->values.find(key);
  return it == table_->values.end() ? nullptr : &it->second;
}

Status SettingsReader::checkBounds(const std::string& key, double v, const Bounds& b) const {
  const bool ok = std::isfinite(v) && (!b.gt || v > *b.gt) && (!b.ge || v >= *b.ge) &&
                  (!b.lt || v < *b.lt) && (!b.le || v <= *b.le);
  if (ok) return Ok{};
  const std::string rule = boundsText(b);
  return invalid(key, rule.empty() ? "must be a finite number" : rule);
}

Result<double> SettingsReader::number(const std::string& key, std::optional<double> fallback,
                                      Bounds bounds) {
  const SettingValue* v = find(key);
  if (!v) {
    if (fallback) return *fallback;
    return missing(key);
  }
  double d = 0;
  if (const auto* i = std::get_if<std::int64_t>(&v->value))
    d = static_cast<double>(*i);
  else if (const auto* f = std::get_if<double>(&v->value))
    d = *f;
  else
    return invalid(key, "must be a number, not " + typeName(v->value));
  if (Status s = checkBounds(key, d, bounds); !s) return s.error();
  return d;
}

Result<std::int64_t> SettingsReader::integer(const std::string& key,
                                             std::optional<std::int64_t> fallback, Bounds bounds) {
  const SettingValue* v = find(key);
  if (!v) {
    if (fallback) return *fallback;
    return missing(key);
  }
  std::int64_t i = 0;
  if (const auto* p = std::get_if<std::int64_t>(&v->value))
    i = *p;
  else if (const auto* f = std::get_if<double>(&v->value);
           f && std::isfinite(*f) && std::floor(*f) == *f && std::abs(*f) < 9e15)
    i = static_cast<std::int64_t>(*f);
  else
    return invalid(key, "must be a whole number");
  if (Status s = checkBounds(key, static_cast<double>(i), bounds); !s) return s.error();
  return i;
}

Result<bool> SettingsReader::boolean(const std::string& key, std::optional<bool> fallback) {
  const SettingValue* v = find(key);
  if (!v) {
    if (fallback) return *fallback;
    return missing(key);
  }
  if (const auto* b = std::get_if<bool>(&v->value)) return *b;
  return invalid(key, "must be true or false");
}

Result<std::string> SettingsReader::text(const std::string& key,
                                         std::optional<std::string> fallback,
                                         const std::vector<std::string>& choices) {
  const SettingValue* v = find(key);
  std::string s;
  if (!v) {
    if (fallback) return *fallback;
    return missing(key);
  }
  if (const auto* p = std::get_if<std::string>(&v->value))
    s = *p;
  else
    return invalid(key, "must be a string (in quotes), not " + typeName(v->value));
  if (!choices.empty()) {
    bool known = false;
    std::string list;
    for (const auto& c : choices) {
      known = known || c == s;
      list += (list.empty() ? "" : ", ") + quoted(c);
    }
    if (!known) return invalid(key, "must be one of " + list);
  }
  return s;
}

Result<std::vector<double>> SettingsReader::numbers(const std::string& key, std::size_t count,
                                                    std::optional<std::vector<double>> fallback,
                                                    Bounds bounds) {
  const SettingValue* v = find(key);
  if (!v) {
    if (fallback) return *fallback;
    return missing(key);
  }
  const auto* arr = std::get_if<std::vector<double>>(&v->value);
  const std::string want = count ? "an array of " + std::to_string(count) + " numbers"
                                 : std::string("an array of numbers");
  if (!arr) return invalid(key, "must be " + want);
  if (count && arr->size() != count) return invalid(key, "must be " + want);
  for (double d : *arr)
    if (Status s = checkBounds(key, d, bounds); !s)
      return invalid(key, "each element " + boundsText(bounds));
  return *arr;
}

Result<std::vector<double>> SettingsReader::numberOrNumbers(const std::string& key,
                                                            std::size_t count,
                                                            std::optional<double> fallback,
                                                            Bounds bounds) {
  const SettingValue* v = find(key);
  if (v && std::holds_alternative<std::vector<double>>(v->value))
    return numbers(key, count, std::nullopt, bounds);
  Result<double> one = number(key, fallback, bounds);
  if (!one) return one.error();
  return std::vector<double>(count, *one);
}

Status SettingsReader::finish(const std::string& reader) const {
  for (const auto& [key, value] : table_->values)
    if (!read_.count(key))
      return fail(where(key) + ": unknown setting for " + reader +
                  " (a typo, or a setting of another backend?)");
  return Ok{};
}

}  // namespace collide::hw
