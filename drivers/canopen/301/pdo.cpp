#include "drivers/canopen/301/pdo.hpp"

#include <stdexcept>
#include <string>

namespace hapticd::drivers::canopen::cia301 {

std::optional<PdoRef> pdo_of_index(std::uint16_t index) noexcept {
  struct Range {
    std::uint16_t base;
    PdoDirection direction;
    bool mapping;
  };
  static constexpr Range ranges[] = {{0x1400, PdoDirection::receive, false},
                                     {0x1600, PdoDirection::receive, true},
                                     {0x1800, PdoDirection::transmit, false},
                                     {0x1A00, PdoDirection::transmit, true}};
  for (const Range& r : ranges) {
    if (index >= r.base && index < r.base + 0x200) return PdoRef{r.direction, index - r.base + 1, r.mapping};
  }
  return std::nullopt;
}

PdoLayout::PdoLayout(std::span<const MappingEntry> entries) {
  if (entries.size() > max_pdo_entries)
    throw std::invalid_argument("a PDO maps at most 8 objects, got " + std::to_string(entries.size()));
  std::size_t bits = 0;
  for (const MappingEntry& e : entries) {
    if (e.bits != 8 && e.bits != 16 && e.bits != 32)
      throw std::invalid_argument("PDO entry " + to_string(e.object) + " has " + std::to_string(e.bits) +
                                  " bits; accepted: 8, 16, 32");
    offsets_[count_] = static_cast<std::uint8_t>(bits / 8);
    entries_[count_++] = e;
    bits += e.bits;
  }
  if (bits > max_pdo_bits)
    throw std::invalid_argument("PDO mapping of " + std::to_string(bits) +
                                " bits exceeds the 64 of a CAN frame");
  bytes_ = bits / 8;
}

std::optional<std::size_t> PdoLayout::find(ObjectAddress object) const noexcept {
  for (std::size_t i = 0; i < count_; ++i)
    if (entries_[i].object == object) return i;
  return std::nullopt;
}

Frame PdoLayout::pack(std::uint32_t can_id, std::span<const std::uint32_t> values) const noexcept {
  Frame f;
  f.id = can_id;
  f.len = static_cast<std::uint8_t>(bytes_);
  for (std::size_t i = 0; i < count_ && i < values.size(); ++i)
    put_le(f.data, offsets_[i], values[i], entries_[i].bits / 8U);
  return f;
}

bool PdoLayout::unpack(const Frame& frame, std::span<std::uint32_t> values) const noexcept {
  if (frame.len < bytes_) return false;
  for (std::size_t i = 0; i < count_ && i < values.size(); ++i)
    values[i] = get_le(frame.data, offsets_[i], entries_[i].bits / 8U);
  return true;
}

std::vector<SdoWrite> pdo_disable_sequence(PdoDirection direction, int number, std::uint32_t can_id) {
  const std::uint16_t comm = pdo_communication_index(direction, number);
  const bool rtr = false;
  return {{{comm, 1}, encode_pdo_cob_id({can_id, false, rtr}), 4}};
}

std::vector<SdoWrite> pdo_configuration_sequence(const PdoConfiguration& pdo) {
  const std::uint16_t comm = pdo_communication_index(pdo.direction, pdo.number);
  const std::uint16_t map = pdo_mapping_index(pdo.direction, pdo.number);
  std::vector<SdoWrite> writes = pdo_disable_sequence(pdo.direction, pdo.number, pdo.can_id);
  const std::size_t n = pdo.layout.count();
  if (n > 0) writes.push_back({{comm, 2}, pdo.transmission_type, 1});
  writes.push_back({{map, 0}, 0, 1});
  if (n == 0) return writes;
  for (std::size_t i = 0; i < n; ++i)
    writes.push_back({{map, static_cast<std::uint8_t>(i + 1)}, encode_mapping(pdo.layout.entry(i)), 4});
  writes.push_back({{map, 0}, static_cast<std::uint32_t>(n), 1});
  writes.push_back({{comm, 1}, encode_pdo_cob_id({pdo.can_id, true, false}), 4});
  return writes;
}

}  // namespace hapticd::drivers::canopen::cia301
