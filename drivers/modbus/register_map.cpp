#include "drivers/modbus/register_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "drivers/modbus/modbus_frame.hpp"

namespace hapticd::drivers::modbus {

namespace {

struct ReadItem {
  const char* key;
  std::uint16_t address;
  int size;
  int* index;
};

std::string hex4(std::uint16_t value) {
  char text[8];
  std::snprintf(text, sizeof text, "0x%04X", value);
  return text;
}

}  // namespace

LayoutResult plan_blocks(const RegisterMap& map) {
  LayoutResult result;
  BlockLayout& l = result.layout;
  auto fail = [&](std::string key, std::string why) {
    result.error_key = std::move(key);
    result.error = std::move(why);
    return result;
  };

  // Write block: torque, and the watchdog beside it when it is rewritten every period.
  l.write_address = map.torque;
  l.write_count = 1;
  l.torque_index = 0;
  if (map.watchdog && written_every_period(map.watchdog_refresh)) {
    const int w = *map.watchdog, t = map.torque;
    if (w == t + 1) {
      l.write_count = 2;
      l.watchdog_index = 1;
    } else if (w + 1 == t) {
      l.write_address = *map.watchdog;
      l.write_count = 2;
      l.watchdog_index = 0;
      l.torque_index = 1;
    } else {
      return fail("watchdog_register",
                  "watchdog_register = " + std::to_string(w) +
                      " is not next to torque_register = " + std::to_string(t) +
                      ": the periodic write (function 16/23) writes one contiguous block; place it at " +
                      std::to_string(t - 1) + " or " + std::to_string(t + 1) +
                      ", or set watchdog_refresh = \"any-frame\" if the amplifier restarts its watchdog on "
                      "every valid frame");
    }
  }

  // Read block: the span of every item read each period.
  std::vector<ReadItem> items;
  items.push_back({"position_register", map.position, 2, &l.position_index});
  if (map.velocity) items.push_back({"velocity_register", *map.velocity, 2, &l.velocity_index});
  if (map.status) items.push_back({"status_register", *map.status, 1, &l.status_index});
  if (map.fault) items.push_back({"fault_register", *map.fault, 1, &l.fault_index});
  for (const ReadItem& it : items) {
    if (it.address + it.size - 1 > 0xFFFF)
      return fail(it.key, std::string(it.key) + " = " + std::to_string(it.address) +
                              " needs two registers; the last address is 65535");
  }
  for (std::size_t i = 0; i < items.size(); ++i)
    for (std::size_t j = i + 1; j < items.size(); ++j) {
      const ReadItem &a = items[i], &b = items[j];
      if (a.address < b.address + b.size && b.address < a.address + a.size)
        return fail(b.key, std::string(b.key) + " = " + std::to_string(b.address) + " overlaps " + a.key +
                               " = " + std::to_string(a.address) + " (" + std::to_string(a.size) +
                               " register" + (a.size > 1 ? "s" : "") + ")");
    }
  int lo = 0xFFFF, hi = 0;
  for (const ReadItem& it : items) {
    lo = std::min(lo, static_cast<int>(it.address));
    hi = std::max(hi, it.address + it.size - 1);
  }
  const int span = hi - lo + 1;
  if (span > limits::read_registers)
    return fail("status_register", "the registers read every period span " + std::to_string(span) +
                                       " registers (" + std::to_string(lo) + " to " + std::to_string(hi) +
                                       "); one request reads at most 125: place position, velocity, "
                                       "status and fault registers closer together");
  l.read_address = static_cast<std::uint16_t>(lo);
  l.read_count = static_cast<std::uint16_t>(span);
  for (const ReadItem& it : items) *it.index = it.address - lo;
  return result;
}

void split_words(std::int32_t value, WordOrder order, std::uint16_t& first, std::uint16_t& second) noexcept {
  const auto bits = static_cast<std::uint32_t>(value);
  const auto high = static_cast<std::uint16_t>(bits >> 16);
  const auto low = static_cast<std::uint16_t>(bits & 0xFFFFu);
  first = order == WordOrder::high_first ? high : low;
  second = order == WordOrder::high_first ? low : high;
}

std::int32_t join_words(std::uint16_t first, std::uint16_t second, WordOrder order) noexcept {
  const std::uint32_t high = order == WordOrder::high_first ? first : second;
  const std::uint32_t low = order == WordOrder::high_first ? second : first;
  return static_cast<std::int32_t>((high << 16) | low);  // two's complement (C++20)
}

void encode_command(const BlockLayout& layout, std::int16_t torque_counts, std::uint16_t watchdog_value,
                    std::span<std::uint16_t> out) noexcept {
  out[static_cast<std::size_t>(layout.torque_index)] = static_cast<std::uint16_t>(torque_counts);
  if (layout.watchdog_index >= 0) out[static_cast<std::size_t>(layout.watchdog_index)] = watchdog_value;
}

AmplifierSample decode_sample(const RegisterMap& map, const BlockLayout& layout,
                              std::span<const std::uint16_t> block) noexcept {
  auto at = [&](int i) { return block[static_cast<std::size_t>(i)]; };
  AmplifierSample s;
  s.position_counts = join_words(at(layout.position_index), at(layout.position_index + 1), map.word_order);
  if (layout.velocity_index >= 0)
    s.velocity_counts = join_words(at(layout.velocity_index), at(layout.velocity_index + 1), map.word_order);
  if (layout.status_index >= 0) s.status = at(layout.status_index);
  if (layout.fault_index >= 0) s.fault = at(layout.fault_index);
  const bool has_status = layout.status_index >= 0;
  s.enabled = !(has_status && map.status_enabled_bit >= 0) || ((s.status >> map.status_enabled_bit) & 1u);
  s.faulted =
      (has_status && map.status_fault_bit >= 0 && ((s.status >> map.status_fault_bit) & 1u)) || s.fault != 0;
  return s;
}

std::int16_t torque_counts(double torque, double per_count, bool& saturated) noexcept {
  saturated = false;
  const double counts = std::nearbyint(torque / per_count);
  constexpr double lo = std::numeric_limits<std::int16_t>::min(),
                   hi = std::numeric_limits<std::int16_t>::max();
  if (!(counts >= lo)) {  // also NaN: the caller refuses non-finite commands first
    saturated = true;
    return std::numeric_limits<std::int16_t>::min();
  }
  if (counts > hi) {
    saturated = true;
    return std::numeric_limits<std::int16_t>::max();
  }
  return static_cast<std::int16_t>(counts);
}

std::string describe_faults(std::uint16_t fault_word, const std::vector<FaultBit>& bits) {
  std::string text;
  for (int bit = 0; bit < 16; ++bit) {
    if (!((fault_word >> bit) & 1u)) continue;
    if (!text.empty()) text += ", ";
    const auto named =
        std::find_if(bits.begin(), bits.end(), [&](const FaultBit& b) { return b.bit == bit; });
    text += named != bits.end() ? named->name : "bit " + std::to_string(bit);
  }
  if (text.empty()) text = "no fault bit set";
  return text + " (fault register " + hex4(fault_word) + ")";
}

std::vector<FaultBit> parse_fault_bits(const std::string& text) {
  std::vector<FaultBit> bits;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    std::string item = text.substr(start, end - start);
    while (!item.empty() && item.front() == ' ') item.erase(item.begin());
    while (!item.empty() && item.back() == ' ') item.pop_back();
    const std::size_t colon = item.find(':');
    int bit = -1;
    if (colon != std::string::npos && colon > 0 && colon <= 2) {
      bit = 0;
      for (std::size_t i = 0; i < colon; ++i) {
        if (item[i] < '0' || item[i] > '9') {
          bit = -1;
          break;
        }
        bit = bit * 10 + (item[i] - '0');
      }
    }
    if (bit < 0 || bit > 15 || colon + 1 >= item.size())
      throw std::invalid_argument("fault_bits item \"" + item +
                                  "\" is not bit:name; accepted: a bit 0..15, a colon and a name, comma "
                                  "separated, e.g. \"0:over-current,2:watchdog\"");
    for (const FaultBit& b : bits)
      if (b.bit == bit) throw std::invalid_argument("fault_bits names bit " + std::to_string(bit) + " twice");
    bits.push_back({bit, item.substr(colon + 1)});
    start = end + 1;
  }
  return bits;
}

std::string format_fault_bits(const std::vector<FaultBit>& bits) {
  std::string text;
  for (const FaultBit& b : bits) {
    if (!text.empty()) text += ",";
    text += std::to_string(b.bit) + ":" + b.name;
  }
  return text;
}

}  // namespace hapticd::drivers::modbus
