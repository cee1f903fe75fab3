// A separate program that talks to the emulated board through its own
// libusb: the test starts it with LD_PRELOAD=libumockdev-preload.so.0 and
// the testbed's UMOCKDEV_DIR, as the end-to-end test starts hapticd.
// usage: usb_hid_probe PERIODS  -> prints "periods=N ok=N in=N out=N"; exit 0

#include <cstdio>
#include <cstdlib>
#include <exception>

#include "drivers/usb_hid/host_session.hpp"
#include "drivers/usb_hid/usb_transport.hpp"

using namespace hapticd::drivers;
using namespace hapticd::drivers::usb_hid;

int main(int argc, char** argv) {
  const int periods = argc > 1 ? std::atoi(argv[1]) : 200;
  try {
    UsbTransport transport(TransportOptions{}, 0x1209, 0x0001);
    UsbSelector selector;
    selector.vendor_id = 0x1209;
    selector.product_id = 0x0001;
    const OpenedBoard board = transport.open(selector);
    transport.start();
    if (!transport.wait_for_in(5.0)) {
      std::fprintf(stderr, "no IN report from %s\n", board.description.c_str());
      return 1;
    }
    HostSession session(ReportLayout{}, SessionLimits{});
    int ok = 0, queued = 0;
    std::uint8_t out[max_report_size];
    for (int p = 0; p < periods; ++p) {
      transport.poll();
      InCompletion in;
      while (transport.pop_in(in)) session.on_in(in.outcome, {in.bytes, in.length}, transport.in_endpoint());
      InReport latest;
      ok += session.end_read(latest) == IoResult::ok ? 1 : 0;
      const std::size_t n = session.make_out(p, true, 3000, out);
      queued += transport.submit_out({out, n}) == SubmitResult::queued ? 1 : 0;
    }
    transport.poll();
    InCompletion in;
    while (transport.pop_in(in)) session.on_in(in.outcome, {in.bytes, in.length}, transport.in_endpoint());
    transport.stop();
    transport.close();
    std::printf("periods=%d ok=%d in=%llu out=%d board=%s\n", periods, ok,
                static_cast<unsigned long long>(session.counters().in_reports), queued,
                board.description.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "usb_hid_probe: %s\n", e.what());
    return 1;
  }
}
