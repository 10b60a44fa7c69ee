// Tests of SessionIndex: reference entries, learning where the slot is empty for the
// keypoint, the learned-entry budget (oldest half forgotten), removal, option checks.
#include "common/session_index.h"

#include <gtest/gtest.h>

#include <set>
#include <utility>
#include <vector>

namespace texfree {
namespace {

using EntryList = std::vector<std::pair<uint32_t, uint16_t>>;

EntryList Entries(const SessionIndex& index, uint64_t hash) {
  std::vector<std::pair<uint32_t, uint16_t>> out;
  index.ForEach(hash, [&](uint32_t d, uint16_t k) { out.emplace_back(d, k); });
  return out;
}

// Distinct, well spread hashes.
uint64_t Hash(uint64_t i) { return (i + 1) * 0x9E3779B97F4A7C15ull; }

TEST(SessionIndexTest, HoldsReferenceDescriptorsPerKeypoint) {
  SessionIndex index;
  // 3 keypoints x 2 descriptors; keypoint 1 has no descriptor (0).
  index.AddDocument(7, {Hash(0), Hash(1), 0, 0, Hash(4), Hash(5)}, 2);
  EXPECT_TRUE(index.Contains(7));
  EXPECT_EQ(index.entries(), 4u);
  EXPECT_EQ(Entries(index, Hash(0)), (EntryList{{7, 0}}));
  EXPECT_EQ(Entries(index, Hash(5)), (EntryList{{7, 2}}));
  EXPECT_TRUE(Entries(index, Hash(2)).empty());
  EXPECT_EQ(index.learned_entries(), 0u);
}

TEST(SessionIndexTest, LearnsOnlyWhereTheSlotIsEmptyForTheKeypoint) {
  SessionIndex index;
  index.AddDocument(7, {Hash(0), Hash(1)}, 1);
  EXPECT_FALSE(index.Learn(Hash(0), 7, 0)) << "keypoint 0 already sits under this descriptor";
  EXPECT_TRUE(index.Learn(Hash(0), 7, 1)) << "another keypoint may share a descriptor";
  EXPECT_TRUE(index.Learn(Hash(9), 7, 0));
  EXPECT_FALSE(index.Learn(Hash(9), 7, 0));
  EXPECT_FALSE(index.Learn(Hash(10), 8, 0)) << "unknown document";
  EXPECT_EQ(index.learned_entries(), 2u);
  EXPECT_EQ(index.learned_entries(7), 2u);
  const auto under0 = Entries(index, Hash(0));
  using EntrySet = std::set<std::pair<uint32_t, uint16_t>>;
  EXPECT_EQ(EntrySet(under0.begin(), under0.end()), (EntrySet{{7, 0}, {7, 1}}));
}

TEST(SessionIndexTest, LearnedEntriesStayWithinTheBudgetForgettingTheOldest) {
  SessionIndexOptions options;
  options.max_learned_entries = 100;
  SessionIndex index(options);
  index.AddDocument(1, {Hash(1000)}, 1);
  for (uint64_t i = 0; i < 1000; ++i) {
    ASSERT_TRUE(index.Learn(Hash(i), 1, static_cast<uint16_t>(i % 50)));
    ASSERT_LE(index.learned_entries(), 100u);
  }
  // The newest are kept, the oldest forgotten; the reference entry survives.
  EXPECT_FALSE(Entries(index, Hash(999)).empty());
  EXPECT_TRUE(Entries(index, Hash(0)).empty());
  EXPECT_FALSE(Entries(index, Hash(1000)).empty());
  EXPECT_EQ(index.entries(), index.learned_entries() + 1);
}

TEST(SessionIndexTest, ZeroBudgetLearnsNothing) {
  SessionIndexOptions options;
  options.max_learned_entries = 0;
  SessionIndex index(options);
  index.AddDocument(1, {Hash(0)}, 1);
  EXPECT_FALSE(index.Learn(Hash(1), 1, 0));
  EXPECT_EQ(index.learned_entries(), 0u);
}

TEST(SessionIndexTest, RemovingADocumentDropsItsReferenceAndLearnedEntries) {
  SessionIndex index;
  index.AddDocument(1, {Hash(0), Hash(1)}, 1);
  index.AddDocument(2, {Hash(2)}, 1);
  ASSERT_TRUE(index.Learn(Hash(5), 1, 0));
  ASSERT_TRUE(index.Learn(Hash(6), 2, 0));
  index.RemoveDocument(1);
  EXPECT_FALSE(index.Contains(1));
  EXPECT_TRUE(Entries(index, Hash(0)).empty());
  EXPECT_TRUE(Entries(index, Hash(5)).empty());
  EXPECT_EQ(Entries(index, Hash(6)), (EntryList{{2, 0}}));
  EXPECT_EQ(index.learned_entries(), 1u);
  EXPECT_EQ(index.entries(), 2u);
}

TEST(SessionIndexTest, OptionsAreValidated) {
  SessionIndexOptions options;
  EXPECT_TRUE(options.Validate().ok());
  options.log2_buckets = 4;
  EXPECT_FALSE(options.Validate().ok());
  options.log2_buckets = 17;
  options.max_learned_entries = 20'000'000;
  EXPECT_FALSE(options.Validate().ok());
}

}  // namespace
}  // namespace texfree
