// CiA 301 codecs byte by byte. Every expected frame is written out from the
// standard's layout (command byte, index little-endian, sub-index, data
// little-endian), not produced by the code under test.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/301/emcy.hpp"
#include "drivers/canopen/301/nmt.hpp"
#include "drivers/canopen/301/object.hpp"
#include "drivers/canopen/301/object_dictionary.hpp"
#include "drivers/canopen/301/pdo.hpp"
#include "drivers/canopen/301/sdo.hpp"

namespace codec_301_test {

namespace co = hapticd::drivers::canopen::cia301;

namespace {

co::Frame frame(std::uint32_t id, std::vector<std::uint8_t> bytes) {
  co::Frame f;
  f.id = id;
  f.len = static_cast<std::uint8_t>(bytes.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) f.data[i] = bytes[i];
  return f;
}

}  // namespace

TEST(CanopenCobId, PredefinedConnectionSet) {
  EXPECT_EQ(co::sdo_request_id(5), 0x605U);
  EXPECT_EQ(co::sdo_response_id(5), 0x585U);
  EXPECT_EQ(co::emcy_id(5), 0x085U);
  EXPECT_EQ(co::heartbeat_id(127), 0x77FU);
  EXPECT_EQ(co::default_rpdo_id(1, 5), 0x205U);
  EXPECT_EQ(co::default_rpdo_id(4, 5), 0x505U);
  EXPECT_EQ(co::default_tpdo_id(1, 5), 0x185U);
  EXPECT_EQ(co::default_tpdo_id(2, 5), 0x285U);
  EXPECT_EQ(co::node_of(0x77F, co::cob::heartbeat), std::uint8_t{127});
  EXPECT_FALSE(co::node_of(0x700, co::cob::heartbeat));  // node 0 does not exist
  EXPECT_FALSE(co::node_of(0x780, co::cob::heartbeat));
}

// ---- SDO: every request and reply form -------------------------------------

TEST(CanopenSdo, UploadRequest) {
  EXPECT_EQ(co::encode_upload_request(5, {0x6041, 0}), frame(0x605, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(co::encode_upload_request(1, {0x1018, 4}), frame(0x601, {0x40, 0x18, 0x10, 0x04, 0, 0, 0, 0}));
}

TEST(CanopenSdo, ExpeditedDownloadOfEachSize) {
  // 1 byte: 0x2F (n = 3, e = s = 1). 0x6060 = 10 (cyclic synchronous torque).
  EXPECT_EQ(co::encode_download_expedited(5, {0x6060, 0}, 10, 1),
            frame(0x605, {0x2F, 0x60, 0x60, 0x00, 0x0A, 0, 0, 0}));
  // 2 bytes: 0x2B. 0x6071 = -100 per mille = 0xFF9C.
  EXPECT_EQ(co::encode_download_expedited(5, {0x6071, 0}, 0xFF9C, 2),
            frame(0x605, {0x2B, 0x71, 0x60, 0x00, 0x9C, 0xFF, 0, 0}));
  // 3 bytes: 0x27.
  EXPECT_EQ(co::encode_download_expedited(5, {0x2000, 1}, 0x123456, 3),
            frame(0x605, {0x27, 0x00, 0x20, 0x01, 0x56, 0x34, 0x12, 0}));
  // 4 bytes: 0x23. 0x1016:01 = node 127, 100 ms.
  EXPECT_EQ(co::encode_download_expedited(5, {0x1016, 1}, 0x007F0064, 4),
            frame(0x605, {0x23, 0x16, 0x10, 0x01, 0x64, 0x00, 0x7F, 0x00}));
  // Only the low `size` bytes travel: the rest of the word is not leaked.
  EXPECT_EQ(co::encode_download_expedited(5, {0x1017, 0}, 0xABCD0064, 2),
            frame(0x605, {0x2B, 0x17, 0x10, 0x00, 0x64, 0x00, 0, 0}));
}

TEST(CanopenSdo, ClientAndServerAbort) {
  EXPECT_EQ(co::encode_client_abort(5, {0x6060, 0}, 0x05040000),
            frame(0x605, {0x80, 0x60, 0x60, 0x00, 0x00, 0x00, 0x04, 0x05}));
  EXPECT_EQ(co::encode_server_abort(5, {0x1600, 1}, 0x06040041),
            frame(0x585, {0x80, 0x00, 0x16, 0x01, 0x41, 0x00, 0x04, 0x06}));
}

TEST(CanopenSdo, ServerResponsesEncoded) {
  EXPECT_EQ(co::encode_upload_response(5, {0x6041, 0}, 0x0237, 2),
            frame(0x585, {0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0, 0}));
  EXPECT_EQ(co::encode_upload_response(5, {0x6061, 0}, 0x0A, 1),
            frame(0x585, {0x4F, 0x61, 0x60, 0x00, 0x0A, 0, 0, 0}));
  EXPECT_EQ(co::encode_upload_response(5, {0x2000, 0}, 0x010203, 3),
            frame(0x585, {0x47, 0x00, 0x20, 0x00, 0x03, 0x02, 0x01, 0}));
  EXPECT_EQ(co::encode_upload_response(5, {0x1000, 0}, 0x00020192, 4),
            frame(0x585, {0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00}));
  EXPECT_EQ(co::encode_download_response(5, {0x6060, 0}), frame(0x585, {0x60, 0x60, 0x60, 0x00, 0, 0, 0, 0}));
}

TEST(CanopenSdo, ClientDecodesEveryResponseForm) {
  using Kind = co::SdoResponse::Kind;
  auto r = co::decode_sdo_response(frame(0x585, {0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0xEE, 0xEE}), 5);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->kind, Kind::upload_expedited);
  EXPECT_EQ(r->address, (co::ObjectAddress{0x6041, 0}));
  EXPECT_EQ(r->size, 2);
  EXPECT_EQ(r->value, 0x0237U);  // bytes beyond the indicated size are not data

  r = co::decode_sdo_response(frame(0x585, {0x4F, 0x61, 0x60, 0x00, 0x0A, 0xEE, 0xEE, 0xEE}), 5);
  EXPECT_EQ(r->size, 1);
  EXPECT_EQ(r->value, 0x0AU);
  r = co::decode_sdo_response(frame(0x585, {0x47, 0x00, 0x20, 0x00, 0x03, 0x02, 0x01, 0xEE}), 5);
  EXPECT_EQ(r->size, 3);
  EXPECT_EQ(r->value, 0x010203U);
  r = co::decode_sdo_response(frame(0x585, {0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00}), 5);
  EXPECT_EQ(r->size, 4);
  EXPECT_EQ(r->value, 0x00020192U);

  // Expedited, size not indicated (0x42): four bytes, size 0.
  r = co::decode_sdo_response(frame(0x585, {0x42, 0x64, 0x60, 0x00, 0x01, 0x02, 0x03, 0x04}), 5);
  EXPECT_EQ(r->kind, Kind::upload_expedited);
  EXPECT_EQ(r->size, 0);
  EXPECT_EQ(r->value, 0x04030201U);

  // Segmented upload initiate (0x41) with the size: the object is longer than 4 bytes.
  r = co::decode_sdo_response(frame(0x585, {0x41, 0x08, 0x10, 0x00, 0x0B, 0, 0, 0}), 5);
  EXPECT_EQ(r->kind, Kind::upload_segmented);
  EXPECT_EQ(r->value, 11U);

  r = co::decode_sdo_response(frame(0x585, {0x60, 0x60, 0x60, 0x00, 0, 0, 0, 0}), 5);
  EXPECT_EQ(r->kind, Kind::download_ack);
  EXPECT_EQ(r->address, (co::ObjectAddress{0x6060, 0}));

  r = co::decode_sdo_response(frame(0x585, {0x80, 0x60, 0x60, 0x00, 0x22, 0x00, 0x00, 0x08}), 5);
  EXPECT_EQ(r->kind, Kind::abort);
  EXPECT_EQ(r->abort_code, 0x08000022U);

  r = co::decode_sdo_response(frame(0x585, {0x20, 0, 0, 0, 0, 0, 0, 0}), 5);  // a download segment response
  EXPECT_EQ(r->kind, Kind::unknown);
  EXPECT_EQ(r->command, 0x20);

  // Other node, other COB-ID, short frame, RTR: not a response for us.
  EXPECT_FALSE(co::decode_sdo_response(frame(0x586, {0x60, 0x60, 0x60, 0, 0, 0, 0, 0}), 5));
  EXPECT_FALSE(co::decode_sdo_response(frame(0x605, {0x60, 0x60, 0x60, 0, 0, 0, 0, 0}), 5));
  EXPECT_FALSE(co::decode_sdo_response(frame(0x585, {0x60, 0x60, 0x60, 0}), 5));
  co::Frame rtr = frame(0x585, {0x60, 0x60, 0x60, 0, 0, 0, 0, 0});
  rtr.id |= co::can_rtr_flag;
  EXPECT_FALSE(co::decode_sdo_response(rtr, 5));
}

TEST(CanopenSdo, ServerDecodesEveryRequestForm) {
  using Kind = co::SdoRequest::Kind;
  auto r = co::decode_sdo_request(frame(0x605, {0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}), 5);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->kind, Kind::upload);
  EXPECT_EQ(r->address, (co::ObjectAddress{0x1018, 1}));

  const std::pair<std::uint8_t, std::uint8_t> sizes[] = {{0x2F, 1}, {0x2B, 2}, {0x27, 3}, {0x23, 4}};
  for (const auto& [command, size] : sizes) {
    r = co::decode_sdo_request(frame(0x605, {command, 0x71, 0x60, 0x00, 0x9C, 0xFF, 0x12, 0x34}), 5);
    EXPECT_EQ(r->kind, Kind::download_expedited);
    EXPECT_EQ(r->size, size);
    const std::uint32_t full = 0x3412FF9C;
    EXPECT_EQ(r->value, size == 4 ? full : full & ((1U << (8 * size)) - 1)) << int(size);
  }
  r = co::decode_sdo_request(frame(0x605, {0x22, 0x71, 0x60, 0x00, 0x9C, 0xFF, 0x00, 0x00}), 5);
  EXPECT_EQ(r->kind, Kind::download_expedited);
  EXPECT_EQ(r->size, 0);  // not indicated

  r = co::decode_sdo_request(frame(0x605, {0x21, 0x08, 0x10, 0x00, 0x10, 0, 0, 0}), 5);
  EXPECT_EQ(r->kind, Kind::download_segmented);
  EXPECT_EQ(r->value, 16U);

  r = co::decode_sdo_request(frame(0x605, {0x80, 0x60, 0x60, 0x00, 0x00, 0x00, 0x04, 0x05}), 5);
  EXPECT_EQ(r->kind, Kind::abort);
  EXPECT_EQ(r->abort_code, 0x05040000U);

  r = co::decode_sdo_request(frame(0x605, {0x60, 0, 0, 0, 0, 0, 0, 0}), 5);  // upload segment request
  EXPECT_EQ(r->kind, Kind::unknown);
  EXPECT_FALSE(co::decode_sdo_request(frame(0x585, {0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}), 5));
}

TEST(CanopenSdo, AbortCodesInWords) {
  EXPECT_EQ(co::describe_abort(0x08000022), "data cannot be stored in the drive's present state");
  EXPECT_EQ(co::describe_abort(0x06040041), "the object cannot be mapped to the PDO");
  EXPECT_EQ(co::describe_abort(0x06020000), "the object does not exist in the object dictionary");
  EXPECT_EQ(co::describe_abort(0x06090011), "the sub-index does not exist");
  EXPECT_EQ(co::describe_abort(0x06010002), "the object is read-only");
  EXPECT_EQ(co::describe_abort(0x06090030), "invalid value for the parameter");
  EXPECT_EQ(co::describe_abort(0x05040000), "SDO protocol timed out");
  EXPECT_EQ(co::describe_abort(0x06070010), "data type does not match: length of the value does not match");
  EXPECT_EQ(co::describe_abort(0x12345678), "abort code not defined by CiA 301");
  // Every named code has its own words.
  for (const std::uint32_t code : {co::abort_code::toggle_bit,
                                   co::abort_code::timed_out,
                                   co::abort_code::unknown_command,
                                   co::abort_code::out_of_memory,
                                   co::abort_code::unsupported_access,
                                   co::abort_code::write_only,
                                   co::abort_code::read_only,
                                   co::abort_code::no_object,
                                   co::abort_code::not_mappable,
                                   co::abort_code::mapping_too_long,
                                   co::abort_code::parameter_incompatible,
                                   co::abort_code::device_incompatible,
                                   co::abort_code::hardware_error,
                                   co::abort_code::length_mismatch,
                                   co::abort_code::length_too_high,
                                   co::abort_code::length_too_low,
                                   co::abort_code::no_sub_index,
                                   co::abort_code::invalid_value,
                                   co::abort_code::value_too_high,
                                   co::abort_code::value_too_low,
                                   co::abort_code::max_below_min,
                                   co::abort_code::no_resource,
                                   co::abort_code::general,
                                   co::abort_code::cannot_store,
                                   co::abort_code::local_control,
                                   co::abort_code::wrong_state,
                                   co::abort_code::no_dictionary,
                                   co::abort_code::no_data})
    EXPECT_NE(co::describe_abort(code), "abort code not defined by CiA 301") << std::hex << code;
}

// ---- NMT, heartbeat, SYNC ---------------------------------------------------

TEST(CanopenNmt, NodeControlFrames) {
  EXPECT_EQ(co::encode_nmt(co::NmtCommand::start, 5), frame(0x000, {0x01, 0x05}));
  EXPECT_EQ(co::encode_nmt(co::NmtCommand::stop, 5), frame(0x000, {0x02, 0x05}));
  EXPECT_EQ(co::encode_nmt(co::NmtCommand::enter_pre_operational, 0), frame(0x000, {0x80, 0x00}));
  EXPECT_EQ(co::encode_nmt(co::NmtCommand::reset_node, 5), frame(0x000, {0x81, 0x05}));
  EXPECT_EQ(co::encode_nmt(co::NmtCommand::reset_communication, 5), frame(0x000, {0x82, 0x05}));

  const auto m = co::decode_nmt(frame(0x000, {0x82, 0x00}));
  ASSERT_TRUE(m);
  EXPECT_EQ(m->command, co::NmtCommand::reset_communication);
  EXPECT_TRUE(co::addresses(*m, 5));  // broadcast
  EXPECT_FALSE(co::addresses(*co::decode_nmt(frame(0x000, {0x01, 0x06})), 5));
  EXPECT_FALSE(co::decode_nmt(frame(0x000, {0x03, 0x05})));  // no such command
  EXPECT_FALSE(co::decode_nmt(frame(0x000, {0x01})));
  EXPECT_FALSE(co::decode_nmt(frame(0x000, {0x01, 0x80})));  // node 128
}

TEST(CanopenNmt, HeartbeatAndBootUp) {
  EXPECT_EQ(co::encode_heartbeat(127, co::NmtState::operational), frame(0x77F, {0x05}));
  EXPECT_EQ(co::encode_heartbeat(5, co::NmtState::pre_operational), frame(0x705, {0x7F}));
  EXPECT_EQ(co::encode_heartbeat(5, co::NmtState::stopped), frame(0x705, {0x04}));
  EXPECT_EQ(co::encode_heartbeat(5, co::NmtState::boot_up), frame(0x705, {0x00}));
  const auto hb = co::decode_heartbeat(frame(0x705, {0x85}));  // node-guarding toggle bit set: ignored
  ASSERT_TRUE(hb);
  EXPECT_EQ(hb->node, 5);
  EXPECT_EQ(hb->state, co::NmtState::operational);
  EXPECT_FALSE(co::decode_heartbeat(frame(0x705, {0x06})));
  EXPECT_FALSE(co::decode_heartbeat(frame(0x705, {0x05, 0x00})));
  EXPECT_FALSE(co::decode_heartbeat(frame(0x700, {0x05})));
}

TEST(CanopenNmt, ConsumerHeartbeatEntry) {
  // 0x1016:n = bits 23..16 node, 15..0 ms.
  EXPECT_EQ(co::encode_consumer_heartbeat(127, 100), 0x007F0064U);
  const auto e = co::decode_consumer_heartbeat(0x00050190);
  EXPECT_EQ(e.node, 5);
  EXPECT_EQ(e.time_ms, 400);
  EXPECT_TRUE(e.used());
  EXPECT_FALSE(co::decode_consumer_heartbeat(0x00050000).used());  // 0 ms
  EXPECT_FALSE(co::decode_consumer_heartbeat(0x00000064).used());  // node 0
}

TEST(CanopenSync, EmptyAndWithCounter) {
  EXPECT_EQ(co::encode_sync(), frame(0x080, {}));
  EXPECT_EQ(co::encode_sync(7), frame(0x080, {0x07}));
  EXPECT_TRUE(co::is_sync(frame(0x080, {})));
  EXPECT_TRUE(co::is_sync(frame(0x080, {0x07})));
  EXPECT_FALSE(co::is_sync(frame(0x081, {})));  // EMCY of node 1
  EXPECT_FALSE(co::is_sync(frame(0x080, {1, 2})));
}

// ---- EMCY -------------------------------------------------------------------

TEST(CanopenEmcy, EncodeDecode) {
  co::Emergency e;
  e.error_code = 0x2310;
  e.error_register = 0x03;
  e.manufacturer = {0x11, 0x22, 0x33, 0x44, 0x55};
  EXPECT_EQ(co::encode_emergency(5, e), frame(0x085, {0x10, 0x23, 0x03, 0x11, 0x22, 0x33, 0x44, 0x55}));
  const auto d = co::decode_emergency(frame(0x085, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0}), 5);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->error_code, 0x8130);
  EXPECT_EQ(d->error_register, 0x11);
  EXPECT_FALSE(co::decode_emergency(frame(0x086, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0}), 5));
  EXPECT_FALSE(co::decode_emergency(frame(0x085, {0x30, 0x81}), 5));
}

TEST(CanopenEmcy, ErrorRegisterAndCommunicationCodesInWords) {
  EXPECT_EQ(co::describe_error_register(0x00), "none");
  EXPECT_EQ(co::describe_error_register(0x03), "generic, current");
  EXPECT_EQ(co::describe_error_register(0x91), "generic, communication, manufacturer-specific");
  EXPECT_EQ(co::describe_communication_error(0x8130), "life guard or heartbeat error");
  EXPECT_EQ(co::describe_communication_error(0x8210), "PDO not processed due to length error");
  EXPECT_EQ(co::describe_communication_error(0x8250), "RPDO timeout");
  EXPECT_EQ(co::describe_communication_error(0x0000), "error reset or no error");
  EXPECT_EQ(co::describe_communication_error(0x81FF), "communication");
  EXPECT_FALSE(co::describe_communication_error(0x2310));
  EXPECT_EQ(co::error_class(0x2310), "current");
  EXPECT_EQ(co::error_class(0x4210), "temperature");
  EXPECT_EQ(co::error_class(0xFF01), "device specific");
  EXPECT_EQ(co::error_class(0xF001), "additional functions");
}

// ---- PDO --------------------------------------------------------------------

TEST(CanopenPdo, ParameterIndices) {
  EXPECT_EQ(co::pdo_communication_index(co::PdoDirection::receive, 1), 0x1400);
  EXPECT_EQ(co::pdo_mapping_index(co::PdoDirection::receive, 4), 0x1603);
  EXPECT_EQ(co::pdo_communication_index(co::PdoDirection::transmit, 2), 0x1801);
  EXPECT_EQ(co::pdo_mapping_index(co::PdoDirection::transmit, 1), 0x1A00);
  const auto ref = co::pdo_of_index(0x1A01);
  ASSERT_TRUE(ref);
  EXPECT_EQ(ref->direction, co::PdoDirection::transmit);
  EXPECT_EQ(ref->number, 2);
  EXPECT_TRUE(ref->mapping);
  EXPECT_FALSE(co::pdo_of_index(0x1C00));
  EXPECT_FALSE(co::pdo_of_index(0x6040));
}

TEST(CanopenPdo, CobIdBitsAndMappingEntries) {
  EXPECT_EQ(co::encode_pdo_cob_id({0x205, true, false}), 0x40000205U);
  EXPECT_EQ(co::encode_pdo_cob_id({0x205, false, false}), 0xC0000205U);
  EXPECT_EQ(co::encode_pdo_cob_id({0x185, true, true}), 0x00000185U);
  EXPECT_EQ(co::decode_pdo_cob_id(0x80000185), (co::PdoCobId{0x185, false, true}));
  EXPECT_EQ(co::encode_mapping({{0x6040, 0}, 16}), 0x60400010U);
  EXPECT_EQ(co::encode_mapping({{0x6071, 0}, 16}), 0x60710010U);
  EXPECT_EQ(co::encode_mapping({{0x6041, 0}, 16}), 0x60410010U);
  EXPECT_EQ(co::encode_mapping({{0x6064, 0}, 32}), 0x60640020U);
  EXPECT_EQ(co::encode_mapping({{0x606C, 0}, 32}), 0x606C0020U);
  EXPECT_EQ(co::decode_mapping(0x60C20208), (co::MappingEntry{{0x60C2, 2}, 8}));
}

TEST(CanopenPdo, LayoutPacksLittleEndianInMappingOrder) {
  const co::MappingEntry rpdo[] = {{{0x6040, 0}, 16}, {{0x6071, 0}, 16}};
  const co::PdoLayout rx(rpdo);
  EXPECT_EQ(rx.bytes(), 4U);
  const std::uint32_t cmd[] = {0x010F, 0xFF06};  // halt + enable operation, -250 per mille
  EXPECT_EQ(rx.pack(0x205, cmd), frame(0x205, {0x0F, 0x01, 0x06, 0xFF}));

  const co::MappingEntry tpdo[] = {{{0x6041, 0}, 16}, {{0x6064, 0}, 32}};
  const co::PdoLayout tx(tpdo);
  EXPECT_EQ(tx.bytes(), 6U);
  EXPECT_EQ(tx.offset(1), 2U);
  std::uint32_t values[2] = {};
  ASSERT_TRUE(tx.unpack(frame(0x185, {0x37, 0x12, 0xFE, 0xFF, 0xFF, 0xFF}), values));
  EXPECT_EQ(values[0], 0x1237U);
  EXPECT_EQ(values[1], 0xFFFFFFFEU);
  EXPECT_FALSE(tx.unpack(frame(0x185, {0x37, 0x12, 0xFE, 0xFF, 0xFF}), values));  // too short: not processed
  EXPECT_TRUE(
      tx.unpack(frame(0x185, {0x37, 0x12, 0xFE, 0xFF, 0xFF, 0xFF, 0xAA}), values));  // extra byte ignored
  EXPECT_EQ(tx.find({0x6064, 0}), std::size_t{1});
  EXPECT_FALSE(tx.find({0x606C, 0}));
}

TEST(CanopenPdo, LayoutRefusesWhatACanFrameCannotCarry) {
  const co::MappingEntry nine_bytes[] = {{{0x6064, 0}, 32}, {{0x606C, 0}, 32}, {{0x6061, 0}, 8}};
  EXPECT_THROW(co::PdoLayout{nine_bytes}, std::invalid_argument);
  const co::MappingEntry odd[] = {{{0x6041, 0}, 12}};
  EXPECT_THROW(co::PdoLayout{odd}, std::invalid_argument);
  const std::vector<co::MappingEntry> nine(9, co::MappingEntry{{0x6061, 0}, 8});
  EXPECT_THROW(co::PdoLayout{nine}, std::invalid_argument);
}

TEST(CanopenPdo, StandardMappingSequence) {
  const co::MappingEntry rpdo[] = {{{0x6040, 0}, 16}, {{0x6071, 0}, 16}};
  co::PdoConfiguration config;
  config.direction = co::PdoDirection::receive;
  config.number = 1;
  config.can_id = 0x205;
  config.transmission_type = 1;
  config.layout = co::PdoLayout(rpdo);
  const std::vector<co::SdoWrite> expected = {
      {{0x1400, 1}, 0xC0000205, 4},                       // 1. not valid (bit 31)
      {{0x1400, 2}, 1, 1},                                // 2. transmission type 1: every SYNC
      {{0x1600, 0}, 0, 1},                                // 3. count 0
      {{0x1600, 1}, 0x60400010, 4},                       // 4. entries
      {{0x1600, 2}, 0x60710010, 4}, {{0x1600, 0}, 2, 1},  // 5. count
      {{0x1400, 1}, 0x40000205, 4},                       // 6. valid again
  };
  EXPECT_EQ(co::pdo_configuration_sequence(config), expected);

  co::PdoConfiguration unused;
  unused.direction = co::PdoDirection::transmit;
  unused.number = 3;
  unused.can_id = 0x385;
  const std::vector<co::SdoWrite> disabled = {{{0x1802, 1}, 0xC0000385, 4}, {{0x1A02, 0}, 0, 1}};
  EXPECT_EQ(co::pdo_configuration_sequence(unused), disabled);
}

// ---- object dictionary basics -----------------------------------------------

TEST(CanopenObject, RawValuesOfEachType) {
  EXPECT_EQ(co::to_raw(co::DataType::integer16, -100), 0xFF9CU);
  EXPECT_EQ(co::to_raw(co::DataType::integer8, -3), 0xFDU);
  EXPECT_EQ(co::to_raw(co::DataType::integer32, -2), 0xFFFFFFFEU);
  EXPECT_EQ(co::to_raw(co::DataType::unsigned32, 0xFFFFFFFF), 0xFFFFFFFFU);
  EXPECT_FALSE(co::to_raw(co::DataType::integer8, 128));
  EXPECT_FALSE(co::to_raw(co::DataType::integer16, -32769));
  EXPECT_FALSE(co::to_raw(co::DataType::unsigned8, 256));
  EXPECT_FALSE(co::to_raw(co::DataType::unsigned16, -1));
  EXPECT_FALSE(co::to_raw(co::DataType::boolean, 2));
  EXPECT_EQ(co::from_raw(co::DataType::integer16, 0xFF9C), -100);
  EXPECT_EQ(co::from_raw(co::DataType::integer8, 0xFD), -3);
  EXPECT_EQ(co::from_raw(co::DataType::integer32, 0x80000000), -2147483648LL);
  EXPECT_EQ(co::from_raw(co::DataType::unsigned16, 0xFFFFFF9C), 0xFF9C);
  EXPECT_EQ(co::size_of(co::DataType::unsigned16), 2);
  EXPECT_EQ(co::parse_data_type("i16"), co::DataType::integer16);
  EXPECT_FALSE(co::parse_data_type("int16"));
  EXPECT_EQ(co::to_string(co::ObjectAddress{0x6041, 0}), "0x6041:00");
}

TEST(CanopenObject, CommunicationObjectsDescribed) {
  const auto hb = co::find_communication_object({0x1017, 0});
  ASSERT_TRUE(hb);
  EXPECT_EQ(hb->type, co::DataType::unsigned16);
  EXPECT_EQ(hb->access, co::Access::rw);
  EXPECT_EQ(co::find_communication_object({0x1016, 3})->type, co::DataType::unsigned32);
  EXPECT_EQ(co::find_communication_object({0x1018, 4})->access, co::Access::ro);
  EXPECT_EQ(co::find_communication_object({0x1A01, 0})->type, co::DataType::unsigned8);
  EXPECT_EQ(co::find_communication_object({0x1601, 8})->type, co::DataType::unsigned32);
  EXPECT_FALSE(co::find_communication_object({0x1601, 9}));
  EXPECT_EQ(co::find_communication_object({0x1800, 2})->type, co::DataType::unsigned8);
  EXPECT_FALSE(co::find_communication_object({0x1800, 4}));
  EXPECT_FALSE(co::find_communication_object({0x1234, 0}));
}

}  // namespace codec_301_test
