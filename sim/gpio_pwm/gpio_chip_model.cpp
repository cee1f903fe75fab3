#include "sim/gpio_pwm/gpio_chip_model.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace hapticd::drivers::gpio_pwm::sim {
namespace {

constexpr std::uint32_t valid_handle_flags =
    GPIOHANDLE_REQUEST_INPUT | GPIOHANDLE_REQUEST_OUTPUT | GPIOHANDLE_REQUEST_ACTIVE_LOW |
    GPIOHANDLE_REQUEST_OPEN_DRAIN | GPIOHANDLE_REQUEST_OPEN_SOURCE | GPIOHANDLE_REQUEST_BIAS_PULL_UP |
    GPIOHANDLE_REQUEST_BIAS_PULL_DOWN | GPIOHANDLE_REQUEST_BIAS_DISABLE;
constexpr std::uint32_t bias_flags =
    GPIOHANDLE_REQUEST_BIAS_PULL_UP | GPIOHANDLE_REQUEST_BIAS_PULL_DOWN | GPIOHANDLE_REQUEST_BIAS_DISABLE;
constexpr std::uint32_t valid_event_flags = GPIOEVENT_REQUEST_RISING_EDGE | GPIOEVENT_REQUEST_FALLING_EDGE;

// linehandle_validate_flags() in gpiolib-cdev.c.
bool handle_flags_valid(std::uint32_t f) {
  if ((f & ~valid_handle_flags) != 0) return false;
  const bool in = (f & GPIOHANDLE_REQUEST_INPUT) != 0;
  const bool out = (f & GPIOHANDLE_REQUEST_OUTPUT) != 0;
  const bool drain = (f & GPIOHANDLE_REQUEST_OPEN_DRAIN) != 0;
  const bool source = (f & GPIOHANDLE_REQUEST_OPEN_SOURCE) != 0;
  if (in && out) return false;
  if (drain && source) return false;
  if (!out && (drain || source)) return false;
  if (!in && !out && (f & bias_flags) != 0) return false;
  return std::popcount(f & bias_flags) <= 1;
}

template <std::size_t N>
void copy_name(char (&out)[N], const std::string& text) {
  std::memset(out, 0, N);
  std::memcpy(out, text.data(), std::min(text.size(), N - 1));
}

std::string name_of(const char* field, std::size_t size) { return std::string(field, strnlen(field, size)); }

}  // namespace

GpioChipModel::GpioChipModel(std::string name, std::string label, std::vector<std::string> line_names)
    : name_(std::move(name)), label_(std::move(label)) {
  if (line_names.empty()) throw std::invalid_argument("GpioChipModel: a chip has at least one line");
  for (auto& n : line_names) lines_.push_back(Line{std::move(n), false, false, std::nullopt});
}

int GpioChipModel::chip_info(gpiochip_info& out) const {
  copy_name(out.name, name_);
  copy_name(out.label, label_);
  out.lines = num_lines();
  return 0;
}

int GpioChipModel::line_info(gpioline_info& info) const {
  if (info.line_offset >= num_lines()) return EINVAL;
  const Line& line = lines_[info.line_offset];
  const std::uint32_t offset = info.line_offset;
  std::memset(&info, 0, sizeof info);
  info.line_offset = offset;
  copy_name(info.name, line.name);
  if (line.is_output) info.flags |= GPIOLINE_FLAG_IS_OUT;
  if (line.owner) {
    const LineRequest& r = requests_.at(*line.owner);
    info.flags |= GPIOLINE_FLAG_KERNEL;
    if (r.active_low()) info.flags |= GPIOLINE_FLAG_ACTIVE_LOW;
    if (r.handle_flags & GPIOHANDLE_REQUEST_OPEN_DRAIN) info.flags |= GPIOLINE_FLAG_OPEN_DRAIN;
    if (r.handle_flags & GPIOHANDLE_REQUEST_OPEN_SOURCE) info.flags |= GPIOLINE_FLAG_OPEN_SOURCE;
    if (r.handle_flags & GPIOHANDLE_REQUEST_BIAS_PULL_UP) info.flags |= GPIOLINE_FLAG_BIAS_PULL_UP;
    if (r.handle_flags & GPIOHANDLE_REQUEST_BIAS_PULL_DOWN) info.flags |= GPIOLINE_FLAG_BIAS_PULL_DOWN;
    if (r.handle_flags & GPIOHANDLE_REQUEST_BIAS_DISABLE) info.flags |= GPIOLINE_FLAG_BIAS_DISABLE;
    copy_name(info.consumer, r.consumer);
  }
  return 0;
}

int GpioChipModel::claim(RequestId id, LineRequest request) {
  for (unsigned offset : request.offsets) {
    if (offset >= num_lines()) return EINVAL;
    if (lines_[offset].owner) return EBUSY;
  }
  for (std::size_t i = 0; i < request.offsets.size(); ++i) {
    if (std::count(request.offsets.begin(), request.offsets.end(), request.offsets[i]) > 1) return EBUSY;
  }
  for (unsigned offset : request.offsets) {
    lines_[offset].owner = id;
    lines_[offset].is_output = request.output();
  }
  requests_[id] = std::move(request);
  return 0;
}

int GpioChipModel::request_handle(RequestId id, const gpiohandle_request& req) {
  if (req.lines == 0 || req.lines > GPIOHANDLES_MAX) return EINVAL;
  if (!handle_flags_valid(req.flags)) return EINVAL;
  LineRequest r;
  r.kind = LineRequest::Kind::handle;
  r.handle_flags = req.flags;
  r.consumer = name_of(req.consumer_label, sizeof req.consumer_label);
  r.offsets.assign(req.lineoffsets, req.lineoffsets + req.lines);
  const bool output = r.output();
  const bool active_low = r.active_low();
  if (const int err = claim(id, std::move(r)); err != 0) return err;
  if (output) {
    for (std::uint32_t i = 0; i < req.lines; ++i) {
      lines_[req.lineoffsets[i]].physical = (req.default_values[i] != 0) != active_low;
    }
  }
  return 0;
}

int GpioChipModel::request_event(RequestId id, const gpioevent_request& req) {
  if (req.lineoffset >= num_lines()) return EINVAL;
  const std::uint32_t f = req.handleflags;
  if ((f & ~valid_handle_flags) != 0 || (req.eventflags & ~valid_event_flags) != 0) return EINVAL;
  if ((f & (GPIOHANDLE_REQUEST_OUTPUT | GPIOHANDLE_REQUEST_OPEN_DRAIN | GPIOHANDLE_REQUEST_OPEN_SOURCE)) != 0)
    return EINVAL;
  if (std::popcount(f & bias_flags) > 1) return EINVAL;
  LineRequest r;
  r.kind = LineRequest::Kind::event;
  r.handle_flags = f;
  r.event_flags = req.eventflags;
  r.consumer = name_of(req.consumer_label, sizeof req.consumer_label);
  r.offsets = {req.lineoffset};
  return claim(id, std::move(r));
}

int GpioChipModel::get_values(RequestId id, gpiohandle_data& out) const {
  const LineRequest* r = request(id);
  if (r == nullptr) return EBADF;
  std::memset(&out, 0, sizeof out);
  for (std::size_t i = 0; i < r->offsets.size(); ++i) {
    out.values[i] = static_cast<std::uint8_t>(lines_[r->offsets[i]].physical != r->active_low());
  }
  return 0;
}

int GpioChipModel::set_values(RequestId id, const gpiohandle_data& values) {
  const LineRequest* r = request(id);
  if (r == nullptr) return EBADF;
  if (r->kind != LineRequest::Kind::handle || !r->output()) return EPERM;
  if (set_values_error_ != 0) return set_values_error_;
  for (std::size_t i = 0; i < r->offsets.size(); ++i) {
    lines_[r->offsets[i]].physical = (values.values[i] != 0) != r->active_low();
  }
  return 0;
}

void GpioChipModel::release(RequestId id) {
  const auto it = requests_.find(id);
  if (it == requests_.end()) return;
  for (unsigned offset : it->second.offsets) lines_[offset].owner.reset();
  requests_.erase(it);
}

std::optional<LineEvent> GpioChipModel::drive_input(unsigned offset, bool physical_level,
                                                    std::uint64_t timestamp_ns) {
  Line& line = lines_.at(offset);
  if (line.is_output && line.owner) throw std::logic_error("GpioChipModel: driving a requested output line");
  const bool changed = line.physical != physical_level;
  line.physical = physical_level;
  if (!changed || !line.owner) return std::nullopt;
  const LineRequest& r = requests_.at(*line.owner);
  if (r.kind != LineRequest::Kind::event) return std::nullopt;
  const bool logical = physical_level != r.active_low();
  const bool rising_wanted = (r.event_flags & GPIOEVENT_REQUEST_RISING_EDGE) != 0;
  const bool falling_wanted = (r.event_flags & GPIOEVENT_REQUEST_FALLING_EDGE) != 0;
  LineEvent event;
  event.request = *line.owner;
  event.data.timestamp = timestamp_ns;
  if (rising_wanted && falling_wanted) {
    event.data.id = logical ? GPIOEVENT_EVENT_RISING_EDGE : GPIOEVENT_EVENT_FALLING_EDGE;
  } else if (rising_wanted && logical) {
    event.data.id = GPIOEVENT_EVENT_RISING_EDGE;
  } else if (falling_wanted && !logical) {
    event.data.id = GPIOEVENT_EVENT_FALLING_EDGE;
  } else {
    return std::nullopt;
  }
  return event;
}

bool GpioChipModel::logical_level(unsigned offset) const {
  const Line& line = lines_.at(offset);
  if (!line.owner) return line.physical;
  return line.physical != requests_.at(*line.owner).active_low();
}

std::optional<unsigned> GpioChipModel::find_line(const std::string& name) const {
  for (unsigned i = 0; i < num_lines(); ++i)
    if (lines_[i].name == name) return i;
  return std::nullopt;
}

const LineRequest* GpioChipModel::request(RequestId id) const {
  const auto it = requests_.find(id);
  return it == requests_.end() ? nullptr : &it->second;
}

}  // namespace hapticd::drivers::gpio_pwm::sim
