#include "hw/pressure_regulator_modbus.hpp"

#include "hw/backend_registry.hpp"
#include "hw/format.hpp"
#include "hw/try.hpp"

namespace collide::hw {

PressureRegulatorModbus::PressureRegulatorModbus(ModbusRegulatorMap map, double max_pressure_kPa,
                                                 std::string device)
    : PressureRegulator("regulator \"" + device + "\""),
      map_(std::move(map)),
      max_pressure_kPa_(max_pressure_kPa),
      device_(std::move(device)),
      link_(map_.link) {}

PressureRegulatorModbus::~PressureRegulatorModbus() = default;

RegulatorInfo PressureRegulatorModbus::info() const {
  return {"modbus", device_, map_.channels, map_.device_min_kPa, map_.device_max_kPa};
}

ModbusRegisterRef PressureRegulatorModbus::setpointRef(int channel) const {
  return {ModbusTable::Holding, map_.setpoint.addresses[static_cast<std::size_t>(channel)],
          map_.setpoint.width(), "setpoint, channel " + std::to_string(channel),
          "regulator.setpoint"};
}

ModbusRegisterRef PressureRegulatorModbus::readbackRef(int channel) const {
  return {map_.readback.table, map_.readback.addresses[static_cast<std::size_t>(channel)],
          map_.readback.width(), "measured pressure, channel " + std::to_string(channel),
          "regulator.readback"};
}

Status PressureRegulatorModbus::lostIfSilent(Status s) {
  if (s || !link_.lastFailureWasSilence()) return s;
  return markLost(s.error().message,
                  "the regulator's power, its cable or network, and regulator.device");
}

Status PressureRegulatorModbus::onOpen() {
  COLLIDE_RETURN_IF_ERROR(lostIfSilent(link_.connect()));
  for (int ch = 0; ch < map_.channels; ++ch) {
    for (const ModbusRegisterRef& ref : {setpointRef(ch), readbackRef(ch)}) {
      if (Result<std::vector<std::uint16_t>> w = link_.read(ref); !w) {
        link_.close();
        return lostIfSilent(w.error());
      }
    }
  }
  return Ok{};
}

Status PressureRegulatorModbus::onConfigure(const RegulatorConfig& config) {
  if (config.max_kPa > max_pressure_kPa_)
    return fail("limit " + num(config.max_kPa) + " kPa is above safety.max_pressure_kpa = " +
                num(max_pressure_kPa_) + " kPa: lower regulator.max_kpa");
  return Ok{};
}

Status PressureRegulatorModbus::onClose() {
  link_.close();
  return Ok{};
}

Status PressureRegulatorModbus::onSetPressureKPa(int channel, double kPa) {
  // Safety before anything reaches the wire, whatever called us (vent() too).
  if (!(kPa <= max_pressure_kPa_))
    return fail(num(kPa) + " kPa on channel " + std::to_string(channel) +
                " is above safety.max_pressure_kpa = " + num(max_pressure_kPa_) +
                " kPa: nothing was written");
  Result<std::vector<std::uint16_t>> words = map_.setpoint.encodeAtMost(kPa);
  if (!words)
    return fail("setpoint " + num(kPa) + " kPa on channel " + std::to_string(channel) +
                " cannot be written: " + words.error().message + " (regulator.setpoint)");
  const double written_kPa = map_.setpoint.decode(words->data());
  if (exceedsKPa(written_kPa, max_pressure_kPa_))
    return fail("setpoint " + num(kPa) + " kPa on channel " + std::to_string(channel) +
                " would be written as " + num(written_kPa) +
                " kPa, above safety.max_pressure_kpa: nothing was written");
  const ModbusRegisterRef ref = setpointRef(channel);
  COLLIDE_RETURN_IF_ERROR(lostIfSilent(link_.write(ref, *words)));
  // Verify: the device must hold what we wrote (not in local mode, not
  // write-protected, not clamped to its own limit).
  Result<std::vector<std::uint16_t>> read_back = link_.read(ref);
  if (!read_back) return lostIfSilent(read_back.error());
  const std::vector<std::uint16_t>& back = *read_back;
  if (back != *words)
    return fail("wrote " + map_.setpoint.rawText(words->data()) + " (" + num(written_kPa) +
                " kPa) to holding register " + std::to_string(ref.address) + " (" + ref.what +
                ") on " + map_.link.describe() + " but it reads back " +
                map_.setpoint.rawText(back.data()) + " (" + num(map_.setpoint.decode(back.data())) +
                " kPa): the device did not take the setpoint: check that it is in remote "
                "(Modbus) mode, not write-protected, and that the value is within its own limits "
                "(retrying will not help until that is fixed)");
  return Ok{};
}

Result<double> PressureRegulatorModbus::onReadPressureKPa(int channel) {
  Result<std::vector<std::uint16_t>> words = link_.read(readbackRef(channel));
  if (!words) return lostIfSilent(words.error()).error();
  return map_.readback.decode(words->data());
}

namespace {

Result<std::unique_ptr<PressureRegulator>> makeModbus(BackendContext& ctx) {
  SettingsReader r = ctx.device.backendSettings();
  COLLIDE_ASSIGN_OR_RETURN(ModbusRegulatorMap map, ModbusRegulatorMap::read(r, ctx.device.device));
  return std::unique_ptr<PressureRegulator>(std::make_unique<PressureRegulatorModbus>(
      std::move(map), ctx.profile.safety.max_pressure_kPa, ctx.device.device));
}

const bool registered = BackendRegistry<PressureRegulator>::instance().add("modbus", &makeModbus);

}  // namespace

}  // namespace collide::hw
