#include "core/util/private_rand.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <thread>
#include <vector>

namespace kgd {
namespace {

std::vector<int> Draws(unsigned seed, int n) {
  std::srand(seed);
  std::vector<int> out;
  for (int i = 0; i < n; ++i) out.push_back(std::rand());
  return out;
}

TEST(PrivateRand, TheExecutableExportsItsRandAndSrandForSharedLibraries) {
  EXPECT_TRUE(PrivateRandIsBound()) << "link with kgd_core's link options (--export-dynamic-symbol=rand,srand)";
}

// Inside a scope: libc's numbers for the seed, whatever another thread draws meanwhile.
TEST(PrivateRand, AScopeGivesLibcsSequenceWhileAnotherThreadDraws) {
  const std::vector<int> libc = Draws(4321, 1000);  // no scope: libc's own rand()
  ASSERT_EQ(libc, Draws(4321, 1000));
  std::atomic<bool> stop{false};
  std::atomic<long> draws{0};
  std::thread other([&] {
    while (!stop) {
      (void)std::rand();
      ++draws;
    }
  });
  while (draws < 1000) std::this_thread::yield();
  std::vector<std::vector<int>> scoped;
  for (int k = 0; k < 200; ++k) {
    PrivateRand scope;
    scoped.push_back(Draws(4321, 1000));
  }
  const long during = draws.load();
  stop = true;
  other.join();
  EXPECT_GT(during, 1000);
  for (const auto& s : scoped) EXPECT_EQ(s, libc);
}

// Before its first srand a scope draws as libc does before any srand (seed 1); a nested scope has a
// state of its own; after the scope the thread is back on libc's state, which the scope did not move.
TEST(PrivateRand, AScopeStartsAtSeedOneAndLeavesLibcsStateAlone) {
  const std::vector<int> seed1 = Draws(1, 10), seed5 = Draws(5, 2);
  std::srand(77);
  const int libc_first = std::rand();
  std::srand(77);
  {
    PrivateRand scope;
    std::vector<int> first;
    for (int i = 0; i < 10; ++i) first.push_back(std::rand());
    EXPECT_EQ(first, seed1);
    std::srand(5);
    EXPECT_EQ(std::rand(), seed5[0]);
    {
      PrivateRand inner;
      EXPECT_EQ(std::rand(), seed1[0]) << "a nested scope has its own state";
    }
    EXPECT_EQ(std::rand(), seed5[1]) << "the outer scope's state goes on";
  }
  EXPECT_EQ(std::rand(), libc_first);
}

}  // namespace
}  // namespace kgd
