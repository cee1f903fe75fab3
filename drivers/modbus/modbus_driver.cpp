#include "drivers/driver_description.hpp"

#include "drivers/modbus/modbus_config.hpp"
#include "drivers/modbus/modbus_device.hpp"

namespace hapticd::drivers::modbus {

namespace {

drivers::ParameterSpec to_spec(const ModbusParameter& p) {
  using S = drivers::ParameterSpec;
  S spec = [&] {
    switch (p.type) {
      case ParameterType::number:
        return S::number(p.name, p.unit, p.help);
      case ParameterType::integer:
        return S::integer(p.name, p.unit, p.help);
      case ParameterType::boolean:
        return S::boolean(p.name, p.help);
      case ParameterType::text:
        return S::text(p.name, p.help);
      case ParameterType::choice:
        return S::choice(p.name, p.accepted, p.help);
      case ParameterType::duration:
        break;
    }
    return S::duration(p.name, p.help);
  }();
  spec.defaults_to(p.default_value, p.default_note);
  if (p.minimum) spec.at_least(*p.minimum);
  if (p.maximum) spec.at_most(*p.maximum);
  return spec;
}

std::vector<drivers::ParameterSpec> specs() {
  std::vector<drivers::ParameterSpec> out;
  for (const ModbusParameter& p : modbus_parameters()) out.push_back(to_spec(p));
  return out;
}

ModbusConfig config_from(const DriverParameters& given) {
  std::map<std::string, ParameterValue> values;
  for (const ModbusParameter& p : modbus_parameters()) {
    switch (p.type) {
      case ParameterType::number:
        values[p.name] = given.number(p.name);
        break;
      case ParameterType::integer:
        values[p.name] = static_cast<double>(given.integer(p.name));
        break;
      case ParameterType::boolean:
        values[p.name] = given.boolean(p.name);
        break;
      case ParameterType::text:
      case ParameterType::choice:
        values[p.name] = given.text(p.name);
        break;
      case ParameterType::duration:
        values[p.name] = given.duration_s(p.name);
        break;
    }
  }
  try {
    return build_modbus_config(values);
  } catch (const ConfigError& e) {
    throw DeviceError(e.what(), e.key());
  }
}

}  // namespace

DriverDescription modbus_driver() {
  return {"modbus", "servo amplifier over Modbus RTU or TCP (libmodbus): fc 23 per period, watchdog register",
          true, specs(), [](const DriverParameters& p) -> std::unique_ptr<DeviceHooks> {
            return std::make_unique<ModbusDevice>(config_from(p));
          }};
}

}  // namespace hapticd::drivers::modbus
