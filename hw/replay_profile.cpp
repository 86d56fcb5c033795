#include "hw/replay_profile.hpp"

#include <toml++/toml.h>

#include <sstream>

namespace collide::hw {

Result<RigProfile> replayProfile(const std::string& recorded, const std::string& recorded_name,
                                 const std::string& source, bool realtime) {
  // The recorded profile parses as a whole first, so its role keys are known.
  auto parsed = parseRigProfile(recorded, recorded_name);
  if (!parsed) return parsed.error();
  toml::table doc, sim;
  try {
    doc = toml::parse(std::string_view(recorded), std::string_view(recorded_name));
    sim = toml::parse(defaultRigProfileText(), std::string_view("config/sim.toml"));
  } catch (const toml::parse_error& e) {
    return fail(recorded_name + ": " + std::string(e.description()));
  }
  toml::table camera;
  camera.insert("backend", "replay");
  camera.insert("source", source);
  camera.insert("realtime", realtime);
  if (const toml::table* old = doc["camera"].as_table()) {
    for (const auto& key : parsed->camera.role_keys) {
      if (key == "backend" || key == "device") continue;
      if (const toml::node* value = old->get(key)) camera.insert(key, *value);
    }
  }
  doc.insert_or_assign("camera", std::move(camera));
  for (const char* role : {"regulator", "valves"}) {
    if (const toml::table* t = sim[role].as_table()) doc.insert_or_assign(role, *t);
  }
  std::ostringstream text;
  text << "# Replay of " << source << " with simulated regulator and valves,\n"
       << "# generated from the profile the shot was recorded with (" << recorded_name << ").\n"
       << doc << "\n";
  const std::string name = "replay profile for " + source;
  auto profile = parseRigProfile(text.str(), name);
  if (!profile)
    return fail(profile.error().message +
                " (the recorded profile's limits do not fit the simulated devices: edit the "
                "recorded profile and use it with backend = \"replay\" by hand)");
  return profile;
}

}  // namespace collide::hw
