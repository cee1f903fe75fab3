#include "drivers/canopen/sdo_client.hpp"
#include "world/text.hpp"

#include <cstdio>

namespace hapticd::drivers::canopen {

using cia301::Frame;
using cia301::SdoResponse;

namespace {}  // namespace

SdoExchange SdoExchange::upload(std::uint8_t node, cia301::ObjectAddress address) {
  SdoExchange e;
  e.node_ = node;
  e.address_ = address;
  e.upload_ = true;
  e.request_ = cia301::encode_upload_request(node, address);
  return e;
}

SdoExchange SdoExchange::download(std::uint8_t node, cia301::ObjectAddress address, std::uint32_t value,
                                  std::uint8_t size) {
  SdoExchange e;
  e.node_ = node;
  e.address_ = address;
  e.upload_ = false;
  e.value_ = value;
  e.size_ = size;
  e.request_ = cia301::encode_download_expedited(node, address, value, size);
  return e;
}

bool SdoExchange::on_frame(const Frame& frame, std::optional<Frame>& reply) {
  reply.reset();
  if (done()) return false;
  const auto r = cia301::decode_sdo_response(frame, node_);
  if (!r || r->address != address_) return false;  // not ours, or a stale answer
  using Kind = SdoResponse::Kind;
  switch (r->kind) {
    case Kind::abort:
      outcome_.kind = SdoOutcome::Kind::aborted;
      outcome_.abort_code = r->abort_code;
      return true;
    case Kind::upload_expedited:
      if (!upload_) break;
      outcome_.kind = SdoOutcome::Kind::ok;
      outcome_.value = r->value;
      outcome_.size = r->size;
      return true;
    case Kind::download_ack:
      if (upload_) break;
      outcome_.kind = SdoOutcome::Kind::ok;
      return true;
    case Kind::upload_segmented:
      if (!upload_) break;
      outcome_.kind = SdoOutcome::Kind::unsupported;
      outcome_.detail = "the object is longer than 4 bytes (a segmented transfer" +
                        (r->value != 0 ? " of " + std::to_string(r->value) + " bytes" : std::string()) +
                        "): only expedited SDO is supported";
      reply = cia301::encode_client_abort(node_, address_, cia301::abort_code::unsupported_access);
      return true;
    case Kind::unknown:
      break;
  }
  outcome_.kind = SdoOutcome::Kind::unsupported;
  outcome_.detail = "the server answered with command " + world::text::format_hex(r->command, 2) +
                    ", which does not fit the request";
  reply = cia301::encode_client_abort(node_, address_, cia301::abort_code::unknown_command);
  return true;
}

Frame SdoExchange::time_out() {
  outcome_.kind = SdoOutcome::Kind::timed_out;
  return cia301::encode_client_abort(node_, address_, cia301::abort_code::timed_out);
}

std::string SdoExchange::describe() const {
  // Mapping entries and COB-IDs read best in hex, small values in decimal.
  const std::string value =
      size_ == 4 && value_ > 0xFFFF ? world::text::format_hex(value_, 8) : std::to_string(value_);
  std::string line =
      upload_
          ? "SDO read " + cia301::to_string(address_) + " from node " + std::to_string(node_)
          : "SDO write " + cia301::to_string(address_) + " = " + value + " to node " + std::to_string(node_);
  switch (outcome_.kind) {
    case SdoOutcome::Kind::pending:
      return line + ": pending";
    case SdoOutcome::Kind::ok:
      return line + (upload_ ? ": " + std::to_string(outcome_.value) : ": done");
    case SdoOutcome::Kind::aborted:
      return line + ": aborted " + world::text::format_hex(outcome_.abort_code, 8) + " (" +
             std::string(cia301::describe_abort(outcome_.abort_code)) + ")";
    case SdoOutcome::Kind::timed_out:
      return line + ": no answer";
    case SdoOutcome::Kind::unsupported:
      return line + ": " + outcome_.detail;
  }
  return line;
}

SdoExchange SdoClient::run(SdoExchange exchange) {
  if (!link_.send(exchange.request())) {
    const Frame abort = exchange.time_out();
    (void)abort;  // nothing went out: nothing to abort
    return exchange;
  }
  // The answer is awaited in slices: a stop request ends the wait within one.
  const SlicedWait wait(stop_, timeout_);
  Frame frame;
  while (!exchange.done()) {
    if (link_.receive(frame, std::chrono::steady_clock::now() + wait.next_slice())) {
      std::optional<Frame> reply;
      if (exchange.on_frame(frame, reply) && reply) link_.send(*reply);
      continue;
    }
    const bool stopped = !wait.expired() && link_.link_error().empty() && wait.stopped();
    if (wait.expired() || !link_.link_error().empty() || stopped) {
      link_.send(exchange.time_out());  // CiA 301: the client aborts what it gives up
      if (stopped) throw StopRequested(abandoned("canopen: " + exchange.describe()));
      break;
    }
  }
  return exchange;
}

std::uint32_t SdoClient::read(cia301::ObjectAddress address) {
  const SdoExchange e = run(SdoExchange::upload(node_, address));
  if (e.outcome().kind != SdoOutcome::Kind::ok) {
    std::string what = e.describe();
    if (e.outcome().kind == SdoOutcome::Kind::timed_out) {
      const std::string why = link_.link_error();
      what += why.empty() ? " within " + std::to_string(timeout_.count() / 1000) + " ms" : " (" + why + ")";
    }
    throw SdoError(what, e.outcome());
  }
  return e.outcome().value;
}

void SdoClient::write(cia301::ObjectAddress address, std::uint32_t value, std::uint8_t size) {
  const SdoExchange e = run(SdoExchange::download(node_, address, value, size));
  if (e.outcome().kind != SdoOutcome::Kind::ok) {
    std::string what = e.describe();
    if (e.outcome().kind == SdoOutcome::Kind::timed_out) {
      const std::string why = link_.link_error();
      what += why.empty() ? " within " + std::to_string(timeout_.count() / 1000) + " ms" : " (" + why + ")";
    }
    throw SdoError(what, e.outcome());
  }
}

}  // namespace hapticd::drivers::canopen
