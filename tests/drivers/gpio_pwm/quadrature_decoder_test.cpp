// x4 quadrature decoding: the 16 transitions, edges from two event queues,
// lost and simultaneous edges, the documented rate bound.
#include <gtest/gtest.h>

#include <random>
#include <tuple>
#include <vector>

#include "drivers/gpio_pwm/quadrature_decoder.hpp"
#include "sim/gpio_pwm/quadrature_encoder.hpp"

namespace hapticd::drivers::gpio_pwm::quadrature_decoder_test {
namespace {

constexpr QuadratureState s00 = quadrature_state(false, false);
constexpr QuadratureState s01 = quadrature_state(false, true);
constexpr QuadratureState s10 = quadrature_state(true, false);
constexpr QuadratureState s11 = quadrature_state(true, true);

// The published sequence with A leading B: 00 -> 10 -> 11 -> 01 -> 00.
TEST(QuadratureDecoder, AllSixteenTransitions) {
  const std::vector<std::tuple<QuadratureState, QuadratureState, Transition>> table{
      {s00, s00, Transition::none},     {s00, s10, Transition::forward},  {s00, s01, Transition::backward},
      {s00, s11, Transition::invalid},  {s10, s10, Transition::none},     {s10, s11, Transition::forward},
      {s10, s00, Transition::backward}, {s10, s01, Transition::invalid},  {s11, s11, Transition::none},
      {s11, s01, Transition::forward},  {s11, s10, Transition::backward}, {s11, s00, Transition::invalid},
      {s01, s01, Transition::none},     {s01, s00, Transition::forward},  {s01, s11, Transition::backward},
      {s01, s10, Transition::invalid},
  };
  ASSERT_EQ(table.size(), 16u);
  for (const auto& [from, to, expected] : table) {
    EXPECT_EQ(classify_transition(from, to), expected) << int(from) << " -> " << int(to);
    QuadratureDecoder d(from);
    EXPECT_EQ(d.sample(to), expected);
    const std::int64_t count = expected == Transition::forward    ? 1
                               : expected == Transition::backward ? -1
                                                                  : 0;
    EXPECT_EQ(d.count(), count);
    EXPECT_EQ(d.invalid_transitions(), expected == Transition::invalid ? 1u : 0u);
    EXPECT_EQ(d.state(), to);  // the new state is taken in every case
  }
}

TEST(QuadratureDecoder, ReverseCountsTheOtherWay) {
  QuadratureDecoder d(s00, true);
  d.sample(s10);
  d.sample(s11);
  EXPECT_EQ(d.count(), -2);
  d.sample(s10);
  EXPECT_EQ(d.count(), -1);
}

TEST(QuadratureDecoder, AFullCycleEachWayIsFourCounts) {
  QuadratureDecoder d(s00);
  for (QuadratureState s : {s10, s11, s01, s00}) d.sample(s);
  EXPECT_EQ(d.count(), 4);
  for (QuadratureState s : {s01, s11, s10, s00}) d.sample(s);
  EXPECT_EQ(d.count(), 0);
  EXPECT_EQ(d.invalid_transitions(), 0u);
}

TEST(QuadratureDecoder, EdgeWithTheLevelTheLineAlreadyHasIsALostEdge) {
  QuadratureDecoder d(s00);
  EXPECT_EQ(d.edge(QuadratureLine::a, true), Transition::forward);
  // A rising again: its falling edge in between was lost.
  EXPECT_EQ(d.edge(QuadratureLine::a, true), Transition::none);
  EXPECT_EQ(d.lost_edges(), 1u);
  EXPECT_EQ(d.count(), 1);
  EXPECT_EQ(d.edges_seen(), 2u);
}

TEST(QuadratureDecoder, EdgesFromTwoQueuesAreMergedByTimestamp) {
  // Forward two cycles, A's and B's edges delivered in separate lists.
  const std::vector<EdgeEvent> a{{100, true}, {300, false}, {500, true}, {700, false}};
  const std::vector<EdgeEvent> b{{200, true}, {400, false}, {600, true}, {800, false}};
  QuadratureDecoder d(s00);
  d.edges(a, b);
  EXPECT_EQ(d.count(), 8);
  EXPECT_EQ(d.invalid_transitions(), 0u);
  EXPECT_EQ(d.lost_edges(), 0u);
  // Had the queues been read one after the other without merging, the count
  // would be wrong: A alone then B alone.
  QuadratureDecoder naive(s00);
  for (const auto& e : a) naive.edge(QuadratureLine::a, e.rising);
  for (const auto& e : b) naive.edge(QuadratureLine::b, e.rising);
  EXPECT_NE(naive.count(), 8);
}

TEST(QuadratureDecoder, SimultaneousEdgesOnBothLinesAreAnImpossibleTransition) {
  QuadratureDecoder d(s00);
  const std::vector<EdgeEvent> a{{100, true}};
  const std::vector<EdgeEvent> b{{100, true}};
  d.edges(a, b);
  EXPECT_EQ(d.invalid_transitions(), 1u);
  EXPECT_EQ(d.count(), 0);
  EXPECT_EQ(d.state(), s11);
  EXPECT_EQ(d.edges_seen(), 2u);
}

// The simulated encoder and the decoder agree over a long random walk: the
// board's edges decode to the board's count, with no error.
TEST(QuadratureDecoder, DecodesTheSimulatedEncoderWithoutError) {
  std::mt19937_64 rng(42);
  std::uniform_int_distribution<int> step(-40, 40);
  sim::QuadratureEncoder encoder(0);
  QuadratureDecoder decoder(quadrature_state(encoder.state().a, encoder.state().b));
  std::int64_t target = 0;
  std::uint64_t t = 0;
  for (int period = 0; period < 2000; ++period) {
    target += step(rng);
    std::vector<sim::EncoderEdge> edges;
    encoder.move_to(target, t, t + 1'000'000, edges);
    t += 1'000'000;
    std::vector<EdgeEvent> a, b;
    for (const auto& e : edges) (e.line == sim::EncoderLine::a ? a : b).push_back({e.timestamp_ns, e.level});
    decoder.edges(a, b);
    ASSERT_EQ(decoder.count(), encoder.count()) << "period " << period;
  }
  EXPECT_EQ(decoder.invalid_transitions(), 0u);
  EXPECT_EQ(decoder.lost_edges(), 0u);
}

TEST(QuadratureDecoder, OneDroppedEdgeIsDetected) {
  sim::QuadratureEncoder encoder(0);
  std::vector<sim::EncoderEdge> edges;
  encoder.move_to(10, 0, 10'000, edges);
  edges.erase(edges.begin() + 4);  // drop one edge, as an overflowing kernel queue would
  std::vector<EdgeEvent> a, b;
  for (const auto& e : edges) (e.line == sim::EncoderLine::a ? a : b).push_back({e.timestamp_ns, e.level});
  QuadratureDecoder decoder(s00);
  decoder.edges(a, b);
  EXPECT_GT(decoder.lost_edges() + decoder.invalid_transitions(), 0u);
  EXPECT_NE(decoder.count(), 10);
}

TEST(QuadratureDecoder, RateBoundFromTheKernelQueueDepth) {
  // 16 events per line, one edge per line every two counts: 32 counts per gap.
  EXPECT_DOUBLE_EQ(max_count_rate(1e-3), 32'000.0);
  EXPECT_DOUBLE_EQ(max_count_rate(100e-6), 320'000.0);
}

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::quadrature_decoder_test
