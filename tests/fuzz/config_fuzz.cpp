// Fuzz target: the config file, as far as the daemon takes it before it
// starts anything: the TOML parser and every section's checks
// (config::parse_config), the driver's typed parameters (build_device),
// configuring the device, and the [scene] through the stability gate
// (plan_on_device). Host checks (paths, groups) are left out: they look at
// the file system, not at the text. Every refusal must be a ConfigError or a
// DeviceError (what hapticd prints as file:line:column: ...) or the gate's
// refusal; any other exception is a message nobody wrote for the user, and
// is reported as a crash.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string_view>
#include <variant>

#include "daemon/config/config.hpp"
#include "daemon/device_factory.hpp"
#include "daemon/planner.hpp"
#include "drivers/device.hpp"

namespace hd = hapticd::daemon;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const auto config = hd::config::parse_config(text, "fuzz.toml");
    auto built = hd::build_device(config);
    built.device->configure(hapticd::drivers::LoopContext{config.loop.period_s});
    const auto model = hd::make_device_model(*built.device, config.loop.period_s);
    hapticd::world::ParameterSet requested;
    bool force = false;
    for (const auto& p : config.scene.parameters) {
      if (p.key == "force") {
        force = std::holds_alternative<bool>(p.value) && std::get<bool>(p.value);
        continue;
      }
      std::visit([&](const auto& v) { requested[p.key] = v; }, p.value);
    }
    const auto outcome = hd::plan_on_device(config.scene.name, requested, model, force);
    if (const auto* refusal = std::get_if<hd::PlanRefusal>(&outcome)) {
      if (refusal->message.empty()) __builtin_trap();  // a refusal must say why
    }
    built.device->close();
  } catch (const hd::config::ConfigError& e) {
    if (std::string_view(e.what()).empty()) __builtin_trap();
  } catch (const hapticd::drivers::DeviceError& e) {
    if (std::string_view(e.what()).empty()) __builtin_trap();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "config: unexpected %s\n", e.what());
    __builtin_trap();
  }
  return 0;
}
