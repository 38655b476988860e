// The program player: a new program replaces the playing one at a block boundary, the old one faded out
// and the new one in along raised cosines, with no click, the buffers handed over and retired lock-free.
//
// Independent expectations: the raised-cosine gains in closed form, g_out(j) = (1 + cos(π(j+1)/F))/2 over
// the old program and g_in(j) = (1 − cos(π·j/F))/2 over the new one from its first sample; and the bound on
// the largest sample-to-sample step of a faded signal g·s: |Δ(g·s)| ≤ max|Δs| + max|s|·max|Δg|, with
// max|Δg| = sin(π/(2F)) ≤ π/(2F) for a raised cosine over F samples — where a switch without a fade
// steps by up to the two programs' peaks together.
#include "engine/program_player.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "engine/program_signal.h"

namespace panelbass::engine {
namespace {

std::vector<double> ramp(std::size_t n, double start) {
  std::vector<double> v(n);
  for (std::size_t k = 0; k < n; ++k) v[k] = start + static_cast<double>(k);
  return v;
}

// `blocks` blocks of `block` samples from `player`, concatenated.
std::vector<double> play(ProgramPlayer& player, int blocks, std::size_t block = 64) {
  std::vector<double> out, b(block);
  for (int i = 0; i < blocks; ++i) {
    player.fill(b);
    out.insert(out.end(), b.begin(), b.end());
  }
  return out;
}

double largest_step(const std::vector<double>& x) {
  double step = 0.0;
  for (std::size_t k = 1; k < x.size(); ++k) step = std::max(step, std::abs(x[k] - x[k - 1]));
  return step;
}

TEST(ProgramPlayer, LoopsItsProgramAndPlaysSilenceForAnEmptyOne) {
  ProgramPlayer player(ramp(5, 1.0), true, 8);
  const std::vector<double> out = play(player, 1, 12);
  for (std::size_t k = 0; k < out.size(); ++k) EXPECT_EQ(out[k], 1.0 + static_cast<double>(k % 5)) << k;
  ProgramPlayer silent({}, true, 8);
  for (const double x : play(silent, 2)) EXPECT_EQ(x, 0.0);
}

TEST(ProgramPlayer, ANewProgramFadesTheOldOutAndItselfInAlongRaisedCosines) {
  const std::size_t fade = 40;
  const std::vector<double> old_program(100, 1.0), new_program = ramp(300, 10.0);
  ProgramPlayer player(old_program, true, fade);
  play(player, 1);  // 64 samples of the old program
  player.install(new_program);
  EXPECT_FALSE(player.idle());
  const std::vector<double> out = play(player, 8);
  const double pi = std::numbers::pi;
  for (std::size_t j = 0; j < fade; ++j) {
    EXPECT_NEAR(out[j], 0.5 * (1.0 + std::cos(pi * static_cast<double>(j + 1) / fade)), 1e-15) << j;
  }
  EXPECT_EQ(out[fade - 1], 0.0);
  for (std::size_t j = 0; j < fade; ++j) {
    EXPECT_NEAR(out[fade + j], new_program[j] * 0.5 * (1.0 - std::cos(pi * static_cast<double>(j) / fade)), 1e-12) << j;
  }
  for (std::size_t j = fade; j < 300; ++j) EXPECT_EQ(out[fade + j], new_program[j]) << j;
  EXPECT_EQ(out[fade + 300], new_program[0]) << "the new program loops";
  EXPECT_TRUE(player.idle());
  EXPECT_EQ(player.collect_retired(), 1u) << "the old buffer, retired by the audio thread, freed here";
}

TEST(ProgramPlayer, ASwitchBetweenSinesStepsNoFurtherThanTheSinesAndTheFadeAllow) {
  const double fs = 3000.0, amplitude = 0.3;
  const LoopedSignal a = looped_sine(80.0, amplitude, fs), b = looped_sine(200.0, amplitude, fs);
  const std::size_t fade = 75;  // 25 ms at 3000 Hz
  const double own_steps = std::max(largest_step(a.samples), largest_step(b.samples));
  const double bound = own_steps + amplitude * std::sin(std::numbers::pi / (2.0 * fade));
  for (int start_block = 0; start_block < 12; ++start_block) {  // switches at different phases of the old sine
    ProgramPlayer player(a.samples, true, fade);
    std::vector<double> out = play(player, start_block, 7);
    player.install(b.samples);
    const std::vector<double> after = play(player, 40, 7);
    out.insert(out.end(), after.begin(), after.end());
    EXPECT_LE(largest_step(out), bound) << "switched after " << start_block << " blocks";
  }
  // Without a fade the same switch clicks: the bound above is one a switch can break.
  double hard = 0.0;
  for (int start_block = 0; start_block < 12; ++start_block) {
    ProgramPlayer player(a.samples, true, 0);
    std::vector<double> out = play(player, start_block, 7);
    player.install(b.samples);
    const std::vector<double> after = play(player, 4, 7);
    out.insert(out.end(), after.begin(), after.end());
    hard = std::max(hard, largest_step(out));
  }
  EXPECT_GT(hard, 2.0 * bound);
}

TEST(ProgramPlayer, AProgramInstalledDuringAFadeWaitsAndOnlyTheLastOnePlays) {
  const std::size_t fade = 30;
  ProgramPlayer player(std::vector<double>(10, 1.0), true, fade);
  player.install(std::vector<double>(10, 2.0));
  play(player, 1, 8);  // taken: the fade is under way
  player.install(std::vector<double>(10, 3.0));
  player.install(std::vector<double>(10, 4.0));  // replaces 3 before it was taken (3 freed here)
  const std::vector<double> out = play(player, 30, 8);
  EXPECT_EQ(out.back(), 4.0);
  EXPECT_EQ(std::count(out.begin(), out.end(), 3.0), 0);
  EXPECT_TRUE(player.idle());
  EXPECT_EQ(player.collect_retired(), 2u);
}

TEST(ProgramPlayer, AProgramPlayedOnceEndsAndSaysHowMuchWasProgram) {
  ProgramPlayer player(ramp(10, 1.0), false, 4);
  std::vector<double> block(8);
  EXPECT_EQ(player.fill(block), 8u);
  EXPECT_EQ(player.fill(block), 2u);
  EXPECT_EQ(block[1], 10.0);
  EXPECT_EQ(block[2], 0.0);
  EXPECT_EQ(player.fill(block), 0u);
  player.install(ramp(3, 5.0));  // played from its start after a fade
  std::vector<double> longer(16);
  // 4 samples of fade-out (of silence), then the 4 of the fade-in, over the 3-sample program played once.
  EXPECT_EQ(player.fill(longer), 8u);
  EXPECT_EQ(longer[7], 0.0);
  EXPECT_NEAR(longer[6], 7.0 * 0.5 * (1.0 - std::cos(std::numbers::pi * 2.0 / 4.0)), 1e-12);
}

}  // namespace
}  // namespace panelbass::engine
