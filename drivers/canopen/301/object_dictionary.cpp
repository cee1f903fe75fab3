#include "drivers/canopen/301/object_dictionary.hpp"

#include "drivers/canopen/301/pdo.hpp"

namespace hapticd::drivers::canopen::cia301 {

std::string_view to_string(Access access) noexcept {
  switch (access) {
    case Access::ro:
      return "ro";
    case Access::wo:
      return "wo";
    case Access::rw:
      return "rw";
    case Access::constant:
      return "const";
  }
  return "?";
}

namespace {

constexpr ObjectInfo fixed_objects[] = {
    {{object::device_type, 0}, DataType::unsigned32, Access::ro, Mappable::no, "device type"},
    {{object::error_register, 0}, DataType::unsigned8, Access::ro, Mappable::tpdo, "error register"},
    {{object::cob_id_sync, 0}, DataType::unsigned32, Access::rw, Mappable::no, "COB-ID SYNC message"},
    {{object::communication_cycle_period, 0},
     DataType::unsigned32,
     Access::rw,
     Mappable::no,
     "communication cycle period (us)"},
    {{object::cob_id_emcy, 0}, DataType::unsigned32, Access::rw, Mappable::no, "COB-ID EMCY"},
    {{object::consumer_heartbeat_time, 0},
     DataType::unsigned8,
     Access::ro,
     Mappable::no,
     "consumer heartbeat time: highest sub-index"},
    {{object::producer_heartbeat_time, 0},
     DataType::unsigned16,
     Access::rw,
     Mappable::no,
     "producer heartbeat time (ms)"},
    {{object::identity, 0}, DataType::unsigned8, Access::ro, Mappable::no, "identity: highest sub-index"},
    {{object::identity, 1}, DataType::unsigned32, Access::ro, Mappable::no, "vendor-ID"},
    {{object::identity, 2}, DataType::unsigned32, Access::ro, Mappable::no, "product code"},
    {{object::identity, 3}, DataType::unsigned32, Access::ro, Mappable::no, "revision number"},
    {{object::identity, 4}, DataType::unsigned32, Access::ro, Mappable::no, "serial number"},
    {{object::error_behavior, 0},
     DataType::unsigned8,
     Access::ro,
     Mappable::no,
     "error behavior: highest sub-index"},
    {{object::error_behavior, 1},
     DataType::unsigned8,
     Access::rw,
     Mappable::no,
     "error behavior: communication error"},
};

std::optional<ObjectInfo> pdo_parameter(ObjectAddress a) noexcept {
  const auto pdo = pdo_of_index(a.index);
  if (!pdo) return std::nullopt;
  if (pdo->mapping) {
    if (a.sub == 0)
      return ObjectInfo{a, DataType::unsigned8, Access::rw, Mappable::no, "number of mapped objects"};
    if (a.sub <= max_pdo_entries)
      return ObjectInfo{a, DataType::unsigned32, Access::rw, Mappable::no, "mapped object"};
    return std::nullopt;
  }
  switch (a.sub) {
    case 0:
      return ObjectInfo{a, DataType::unsigned8, Access::ro, Mappable::no,
                        "PDO communication: highest sub-index"};
    case 1:
      return ObjectInfo{a, DataType::unsigned32, Access::rw, Mappable::no, "COB-ID used by the PDO"};
    case 2:
      return ObjectInfo{a, DataType::unsigned8, Access::rw, Mappable::no, "transmission type"};
    case 3:
      return ObjectInfo{a, DataType::unsigned16, Access::rw, Mappable::no, "inhibit time (100 us)"};
    case 5:
      return ObjectInfo{a, DataType::unsigned16, Access::rw, Mappable::no, "event timer (ms)"};
    default:
      return std::nullopt;
  }
}

}  // namespace

std::optional<ObjectInfo> find_communication_object(ObjectAddress address) noexcept {
  for (const ObjectInfo& info : fixed_objects)
    if (info.address == address) return info;
  if (address.index == object::consumer_heartbeat_time && address.sub >= 1 && address.sub <= 127)
    return ObjectInfo{address, DataType::unsigned32, Access::rw, Mappable::no, "consumer heartbeat time"};
  return pdo_parameter(address);
}

}  // namespace hapticd::drivers::canopen::cia301
