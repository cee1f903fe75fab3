#pragma once
/// \file
/// A device model that replaces the driver's for the stability gate: from a
/// model file (`[device] model = "path"`, written by `hapticctl identify`)
/// or from the control method device.model.set, both the same [model] keys
/// (docs/config.md, "Device model files"); and the model in force as JSON
/// (device.model), complete enough for a client to redo the gate's analysis.

#include <string>

#include <nlohmann/json.hpp>

#include "daemon/config/config.hpp"
#include "daemon/planner.hpp"
#include "drivers/device.hpp"

namespace hapticd::daemon {

/// The model the [model] keys describe, for the device the driver describes
/// (its motion must match; its encoder resolution is kept) at the loop's
/// period (the file's must match: the delay is counted in periods).
/// `source` becomes DeviceModel::source. Throws config::ConfigError at the
/// bad key's position ("model.<key>"), or at `where` for a missing one.
drivers::DeviceModel model_from_keys(const config::ParameterList& keys, const drivers::DeviceModel& driver,
                                     double period_s, std::string source,
                                     const config::SourcePosition& where);

/// device.model.set's "model" object as keys (no positions). Throws
/// std::invalid_argument for a value that is not a number, string or boolean.
config::ParameterList keys_from_json(const nlohmann::json& object);

/// The model in force: what the driver says, the plant the gate analyses
/// (state space, inputs [motor force, hand force]) and where it came from.
nlohmann::json to_json(const DeviceModel& model);

}  // namespace hapticd::daemon
