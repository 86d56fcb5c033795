// Fuzz target: the rig profile parser (TOML text -> RigProfile), which reads
// files users edit by hand. Any input must give a profile or a one-line error,
// never a crash, a hang or undefined behaviour.
#include <cstddef>
#include <cstdint>
#include <string>

#include "hw/rig_profile.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  auto profile = collide::hw::parseRigProfile(text, "fuzz.toml");
  if (!profile && profile.error().message.empty()) __builtin_trap();  // errors must say something
  return 0;
}
