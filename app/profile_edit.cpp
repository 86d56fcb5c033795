#include "app/profile_edit.hpp"

#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <vector>

#include "app/store/atomic_file.hpp"

namespace collide::app {
namespace {

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

}  // namespace

Result<std::string> setProfileValue(const std::string& text, const std::string& section,
                                    const std::string& key, const std::string& toml_value) {
  std::vector<std::string> ls = lines(text);
  // [section] header, and the line after the section's last key.
  std::size_t start = ls.size();
  for (std::size_t i = 0; i < ls.size(); ++i) {
    const std::string t = trim(ls[i]);
    if (t.rfind("[" + section + "]", 0) == 0) {
      start = i;
      break;
    }
  }
  if (start == ls.size())
    return fail("the rig profile has no [" + section + "] section to set " + section + "." + key +
                " in");
  std::size_t end = start + 1, last_key = start;
  const std::regex key_re("^\\s*" + key + "\\s*=");
  for (; end < ls.size(); ++end) {
    const std::string t = trim(ls[end]);
    if (!t.empty() && t[0] == '[') break;
    if (!t.empty() && t[0] != '#') last_key = end;
    if (std::regex_search(ls[end], key_re)) {
      // Keep a trailing comment: it documents the field. A '#' inside a string
      // value is not a comment, so look for it after the value only.
      const std::string& line = ls[end];
      const std::size_t eq = line.find('=');
      std::string rest = line.substr(eq + 1);
      std::size_t hash = std::string::npos;
      bool in_string = false;
      int depth = 0;
      for (std::size_t k = 0; k < rest.size(); ++k) {
        const char c = rest[k];
        if (c == '"') in_string = !in_string;
        if (in_string) continue;
        if (c == '[') ++depth;
        if (c == ']') --depth;
        if (c == '#' && depth <= 0) {
          hash = k;
          break;
        }
      }
      std::string value_part = hash == std::string::npos ? rest : rest.substr(0, hash);
      std::string comment = hash == std::string::npos ? "" : rest.substr(hash);
      std::string replaced = line.substr(0, eq + 1) + " " + toml_value;
      if (!comment.empty()) {
        // Keep the comment's column where the new value allows it.
        const std::size_t column = eq + 1 + value_part.size();
        replaced += std::string(replaced.size() < column ? column - replaced.size() : 1, ' ');
        replaced += comment;
      }
      ls[end] = replaced;
      std::string out;
      for (const auto& l : ls) out += l + "\n";
      return out;
    }
  }
  ls.insert(ls.begin() + static_cast<std::ptrdiff_t>(last_key + 1), key + " = " + toml_value);
  std::string out;
  for (const auto& l : ls) out += l + "\n";
  return out;
}

Result<std::string> setProfileTable(
    const std::string& text, const std::string& section,
    const std::vector<std::pair<std::string, std::string>>& entries) {
  std::vector<std::string> ls = lines(text);
  const auto header = [](const std::string& line) {
    const std::string t = trim(line);
    return !t.empty() && t[0] == '[';
  };
  const auto isTable = [&](const std::string& line, const std::string& name) {
    return trim(line).rfind("[" + name + "]", 0) == 0;
  };
  std::vector<std::string> body{"[" + section + "]"};
  for (const auto& [key, value] : entries) body.push_back(key + " = " + value);
  std::size_t start = ls.size();
  for (std::size_t i = 0; i < ls.size(); ++i)
    if (isTable(ls[i], section)) start = i;
  if (start < ls.size()) {
    std::size_t end = start + 1;
    while (end < ls.size() && !header(ls[end])) ++end;
    // Keep the blank lines and comments that lead into the next table.
    while (end > start + 1 && (trim(ls[end - 1]).empty() || trim(ls[end - 1])[0] == '#')) --end;
    ls.erase(ls.begin() + static_cast<std::ptrdiff_t>(start),
             ls.begin() + static_cast<std::ptrdiff_t>(end));
    ls.insert(ls.begin() + static_cast<std::ptrdiff_t>(start), body.begin(), body.end());
  } else {
    const std::size_t dot = section.rfind('.');
    std::size_t at = ls.size();
    if (dot != std::string::npos) {
      const std::string parent = section.substr(0, dot);
      std::size_t p = ls.size();
      for (std::size_t i = 0; i < ls.size(); ++i)
        if (isTable(ls[i], parent)) p = i;
      if (p == ls.size())
        return fail("the rig profile has no [" + parent + "] table to add [" + section + "] to");
      // After the parent's last sub-table: up to the first header that is
      // neither [parent] nor [parent.*].
      at = p + 1;
      while (at < ls.size() && (!header(ls[at]) || trim(ls[at]).rfind("[" + parent + ".", 0) == 0))
        ++at;
      while (at > p + 1 && (trim(ls[at - 1]).empty() || trim(ls[at - 1])[0] == '#')) --at;
    }
    body.insert(body.begin(), "");
    ls.insert(ls.begin() + static_cast<std::ptrdiff_t>(at), body.begin(), body.end());
  }
  std::string out;
  for (const auto& l : ls) out += l + "\n";
  return out;
}

std::string tomlNumberArray(const std::array<double, 4>& v) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "[%.17g, %.17g, %.17g, %.17g]", v[0], v[1], v[2], v[3]);
  return buf;
}

Status writeProfileFile(const std::string& path, const std::string& text,
                        std::string* backup_path) {
  std::error_code ec;
  if (std::filesystem::exists(path, ec)) {
    const std::string backup = path + ".bak";
    auto copy = AtomicFile::createCopyOf(path, backup);
    if (!copy) return copy.error();
    if (Status s = copy->commit(); !s) return s;
    if (backup_path) *backup_path = backup;
  }
  return writeTextFile(path, text);
}

}  // namespace collide::app
