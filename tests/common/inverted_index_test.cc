// Tests of InvertedIndex: adding, looking up, counting and removing (document, keypoint)
// entries under 64-bit descriptor hashes, including bucket collisions and entry reuse.
#include "common/inverted_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <utility>
#include <vector>

namespace texfree {
namespace {

using Entry = std::pair<uint32_t, uint16_t>;

std::multiset<Entry> Lookup(const InvertedIndex& index, uint64_t hash) {
  std::multiset<Entry> out;
  index.ForEach(hash, [&](uint32_t doc, uint16_t kp) { out.emplace(doc, kp); });
  return out;
}

// Random non-zero hashes, `per_point` per keypoint.
std::vector<uint64_t> RandomHashes(std::mt19937_64& rng, int points, int per_point) {
  std::vector<uint64_t> h(static_cast<size_t>(points) * per_point);
  for (auto& x : h) {
    do {
      x = rng();
    } while (x == 0);
  }
  return h;
}

TEST(InvertedIndexTest, AddThenForEachFindsEveryEntry) {
  std::mt19937_64 rng(1);
  InvertedIndex index(16);
  const int per = 7;
  std::map<uint32_t, std::vector<uint64_t>> docs;
  for (uint32_t d = 1; d <= 5; ++d) {
    docs[d] = RandomHashes(rng, 200, per);
    index.Add(d, docs[d], per);
  }
  EXPECT_EQ(index.entries(), 5u * 200 * per);
  for (const auto& [d, hashes] : docs) {
    for (size_t i = 0; i < hashes.size(); ++i) {
      const auto found = Lookup(index, hashes[i]);
      EXPECT_EQ(found.count({d, static_cast<uint16_t>(i / per)}), 1u) << d << " " << i;
    }
  }
}

TEST(InvertedIndexTest, SameHashFromSeveralDocumentsAndKeypoints) {
  InvertedIndex index(10);
  const uint64_t h = 0x0123456789ABCDEFull;
  index.Add(3, {h, 5, h}, 1);  // keypoints 0 and 2 of document 3
  index.Add(9, {7, 8, h}, 3);  // keypoint 0 of document 9 (slot 2 / 3 per point)
  EXPECT_EQ(Lookup(index, h), (std::multiset<Entry>{{3, 0}, {3, 2}, {9, 0}}));
  EXPECT_EQ(index.Count(h, 100), 3);
  EXPECT_EQ(Lookup(index, 5), (std::multiset<Entry>{{3, 1}}));
  EXPECT_TRUE(Lookup(index, 6).empty());
}

TEST(InvertedIndexTest, ZeroHashesAreSkipped) {
  InvertedIndex index(10);
  index.Add(1, {0, 0, 42, 0}, 2);
  EXPECT_EQ(index.entries(), 1u);
  EXPECT_EQ(Lookup(index, 42), (std::multiset<Entry>{{1, 1}}));
  EXPECT_FALSE(index.AddIfAbsent(0, 1, 0));
  EXPECT_EQ(index.entries(), 1u);
}

TEST(InvertedIndexTest, CheckBitsSeparateHashesSharingABucket) {
  // Bucket = top log2_buckets bits; check = low 16 bits. Same bucket, different check.
  InvertedIndex index(8);
  const uint64_t a = 0xAB00000000001111ull, b = 0xAB00000000002222ull;
  index.Add(1, {a}, 1);
  index.Add(2, {b}, 1);
  EXPECT_EQ(Lookup(index, a), (std::multiset<Entry>{{1, 0}}));
  EXPECT_EQ(Lookup(index, b), (std::multiset<Entry>{{2, 0}}));
  EXPECT_EQ(index.Count(a, 10), 1);
  // A different bucket with the same check bits finds nothing.
  EXPECT_TRUE(Lookup(index, 0xAC00000000001111ull).empty());
}

TEST(InvertedIndexTest, RemoveOneDocumentLeavesOthersIntact) {
  std::mt19937_64 rng(2);
  InvertedIndex index(14);
  const int per = 7;
  const auto h1 = RandomHashes(rng, 150, per), h2 = RandomHashes(rng, 150, per);
  auto h3 = RandomHashes(rng, 150, per);
  // Document 3 shares some descriptors with document 2: removing 2 must not take 3's.
  for (size_t i = 0; i < h3.size(); i += 5) h3[i] = h2[i];
  index.Add(1, h1, per);
  index.Add(2, h2, per);
  const size_t before = index.entries();
  index.Add(3, h3, per);
  const size_t with_three = index.entries();
  EXPECT_EQ(with_three, before + h3.size());

  EXPECT_EQ(index.Remove(3, h3, per), h3.size());
  EXPECT_EQ(index.entries(), before);
  for (size_t i = 0; i < h3.size(); ++i) {
    for (const auto& [d, kp] : Lookup(index, h3[i])) EXPECT_NE(d, 3u);
  }
  for (size_t i = 0; i < h2.size(); ++i)
    EXPECT_EQ(Lookup(index, h2[i]).count({2, static_cast<uint16_t>(i / per)}), 1u) << i;
  for (size_t i = 0; i < h1.size(); ++i)
    EXPECT_EQ(Lookup(index, h1[i]).count({1, static_cast<uint16_t>(i / per)}), 1u) << i;

  // Removing again finds nothing; re-adding reuses the freed entries.
  EXPECT_EQ(index.Remove(3, h3, per), 0u);
  const size_t memory = index.MemoryBytes();
  index.Add(3, h3, per);
  EXPECT_EQ(index.entries(), with_three);
  EXPECT_EQ(index.MemoryBytes(), memory) << "freed entries should be reused";
  for (size_t i = 0; i < h3.size(); ++i)
    EXPECT_EQ(Lookup(index, h3[i]).count({3, static_cast<uint16_t>(i / per)}), 1u) << i;
}

TEST(InvertedIndexTest, RemoveUnknownDocumentRemovesNothing) {
  std::mt19937_64 rng(3);
  InvertedIndex index(12);
  const auto h = RandomHashes(rng, 50, 3);
  index.Add(1, h, 3);
  EXPECT_EQ(index.Remove(2, h, 3), 0u);
  EXPECT_EQ(index.entries(), h.size());
}

TEST(InvertedIndexTest, AddIfAbsentRefusesDuplicate) {
  InvertedIndex index(10);
  const uint64_t h = 0xDEADBEEFCAFEF00Dull;
  EXPECT_TRUE(index.AddIfAbsent(h, 4, 17));
  EXPECT_FALSE(index.AddIfAbsent(h, 4, 17));
  EXPECT_EQ(index.entries(), 1u);
  EXPECT_TRUE(index.AddIfAbsent(h, 4, 18));      // other keypoint
  EXPECT_TRUE(index.AddIfAbsent(h, 5, 17));      // other document
  EXPECT_TRUE(index.AddIfAbsent(h ^ 1, 4, 17));  // other descriptor, same bucket
  EXPECT_EQ(index.entries(), 4u);
  EXPECT_EQ(Lookup(index, h), (std::multiset<Entry>{{4, 17}, {4, 18}, {5, 17}}));
  // An entry made by Add() counts as present too.
  index.Add(6, {h}, 1);
  EXPECT_FALSE(index.AddIfAbsent(h, 6, 0));
}

// The start-up batch load holds exactly the entries Add() would, on top of what the index
// already holds, and they can be removed one document at a time as usual.
TEST(InvertedIndexTest, AddBatchEqualsAddAndSupportsRemove) {
  std::mt19937_64 rng(77);
  std::vector<std::vector<uint64_t>> docs(30);
  for (auto& d : docs) {
    d.resize(3 * 40);
    for (auto& h : d) h = rng() % 5 == 0 ? 0x1234567800000000ull + rng() % 3 : rng();
    d[5] = 0;  // "no descriptor" slots are skipped
  }
  InvertedIndex one_by_one(12), batched(12);
  one_by_one.Add(500, docs[0], 3);
  batched.Add(500, docs[0], 3);  // already indexed before the batch
  std::vector<InvertedIndex::Batch> batch;
  for (size_t d = 1; d < docs.size(); ++d) {
    one_by_one.Add(static_cast<uint32_t>(d), docs[d], 3);
    batch.push_back({static_cast<uint32_t>(d), &docs[d]});
  }
  batched.AddBatch(batch, 3);
  EXPECT_EQ(batched.entries(), one_by_one.entries());
  for (const auto& d : docs)
    for (uint64_t h : d) EXPECT_EQ(Lookup(batched, h), Lookup(one_by_one, h));
  // Threads sharing the load (each a range of buckets, and a sketch row) build the same.
  for (int threads : {2, 3}) {
    InvertedIndex threaded(12);
    threaded.Add(500, docs[0], 3);
    threaded.AddBatch(batch, 3, threads);
    EXPECT_EQ(threaded.entries(), one_by_one.entries()) << threads << " threads";
    for (const auto& d : docs)
      for (uint64_t h : d) {
        EXPECT_EQ(Lookup(threaded, h), Lookup(one_by_one, h)) << threads << " threads";
        for (int limit : {0, 1, 2, 5})
          EXPECT_EQ(threaded.LikelyExceeds(h, limit), one_by_one.LikelyExceeds(h, limit));
      }
  }
  EXPECT_EQ(batched.Remove(7, docs[7], 3), 119u);
  EXPECT_EQ(batched.Remove(500, docs[0], 3), 119u);
  one_by_one.Remove(7, docs[7], 3);
  one_by_one.Remove(500, docs[0], 3);
  for (const auto& d : docs)
    for (uint64_t h : d) EXPECT_EQ(Lookup(batched, h), Lookup(one_by_one, h));
}

TEST(InvertedIndexTest, CountStopsAtLimit) {
  InvertedIndex index(10);
  const uint64_t h = 0x5555AAAA5555AAAAull;
  for (uint16_t kp = 0; kp < 30; ++kp) index.AddIfAbsent(h, 1, kp);
  index.AddIfAbsent(h ^ 0x1, 2, 0);  // same bucket, other check: not counted
  EXPECT_EQ(index.Count(h, 100), 30);
  EXPECT_EQ(index.Count(h, 30), 30);
  EXPECT_EQ(index.Count(h, 25), 25);
  EXPECT_EQ(index.Count(h, 1), 1);
  EXPECT_EQ(index.Count(h, 0), 0);
  EXPECT_EQ(index.Count(0x1234, 100), 0);
  // One walk: every entry up to the limit, then limit + 1 to say "more".
  int calls = 0;
  EXPECT_EQ(index.ForEachUpTo(h, 100, [&](uint32_t doc, uint16_t) { calls += doc == 1; }), 30);
  EXPECT_EQ(calls, 30);
  calls = 0;
  EXPECT_EQ(index.ForEachUpTo(h, 30, [&](uint32_t, uint16_t) { ++calls; }), 30);
  EXPECT_EQ(calls, 30);
  calls = 0;
  EXPECT_EQ(index.ForEachUpTo(h, 24, [&](uint32_t, uint16_t) { ++calls; }), 25);
  EXPECT_EQ(calls, 24);
  EXPECT_EQ(index.ForEachUpTo(0x1234, 5, [&](uint32_t, uint16_t) { ++calls; }), 0);
}

// Memory is the table plus 12 bytes an entry, allocated in blocks of 2^16 entries that
// never move (no doubling copy): never more than one block beyond the entries.
TEST(InvertedIndexTest, MemoryGrowsWithEntries) {
  std::mt19937_64 rng(4);
  InvertedIndex index(12);
  const size_t empty = index.MemoryBytes();
  EXPECT_GE(empty, (size_t{1} << 12) * sizeof(uint32_t));
  constexpr size_t kBlock = size_t{1} << 16;
  size_t entries = 0;
  for (uint32_t document = 1; document <= 40; ++document) {
    index.Add(document, RandomHashes(rng, 1000, 7), 7);
    entries += 7000;
    const size_t bytes = index.MemoryBytes();
    EXPECT_GE(bytes, empty + entries * 12);
    EXPECT_LE(bytes, empty + (entries + kBlock) * 12) << "at " << entries << " entries";
  }
  // Entries added across many blocks are all found.
  std::mt19937_64 again(4);
  for (uint32_t document = 1; document <= 40; ++document) {
    const auto hashes = RandomHashes(again, 1000, 7);
    for (size_t i = 0; i < hashes.size(); i += 997)
      EXPECT_EQ(Lookup(index, hashes[i]).count({document, static_cast<uint16_t>(i / 7)}), 1u);
  }
}

// The table is sized for its entries (chains of ~16), within the given floor and the cap;
// an empty index takes another size and finds what is added after, a filled one refuses.
TEST(InvertedIndexTest, TableIsSizedForItsEntries) {
  EXPECT_EQ(InvertedIndex::Log2BucketsFor(0, 22), 22);
  EXPECT_EQ(InvertedIndex::Log2BucketsFor((size_t{16} << 22), 22), 22);
  EXPECT_EQ(InvertedIndex::Log2BucketsFor((size_t{16} << 22) + 1, 22), 23);
  EXPECT_EQ(InvertedIndex::Log2BucketsFor(size_t{750'000'000}, 22), 26);  // 100,000 pages
  EXPECT_EQ(InvertedIndex::Log2BucketsFor(size_t{1} << 40, 22), InvertedIndex::kMaxLog2Buckets);
  EXPECT_EQ(InvertedIndex::Log2BucketsFor(1000, 10), 10);

  InvertedIndex index(10);
  ASSERT_TRUE(index.Rebucket(14));
  EXPECT_EQ(index.log2_buckets(), 14);
  EXPECT_GE(index.MemoryBytes(), (size_t{1} << 14) * sizeof(uint32_t));
  index.Add(3, {0x123456789ABCDEFull, 0xFEDCBA9876543210ull}, 1);
  EXPECT_EQ(Lookup(index, 0xFEDCBA9876543210ull), (std::multiset<Entry>{{3, 1}}));
  EXPECT_FALSE(index.Rebucket(16));
  EXPECT_EQ(index.log2_buckets(), 14);
}

TEST(InvertedIndexTest, ReserveDoesNotChangeContents) {
  InvertedIndex index(10);
  index.Add(1, {11, 22}, 1);
  index.Reserve(10000);
  EXPECT_EQ(index.entries(), 2u);
  EXPECT_GE(index.MemoryBytes(), size_t{10000} * 12);
  EXPECT_EQ(Lookup(index, 22), (std::multiset<Entry>{{1, 1}}));
}

// The stop-word sketch bounds every hash's count from above (never calls a rare descriptor
// common) and follows adds, bulk loads and removals.
TEST(InvertedIndexTest, LikelyExceedsBoundsCountsThroughAddsAndRemovals) {
  std::mt19937_64 rng(7);
  InvertedIndex index(12);  // small sketch: 4096 counters per row, so collisions happen
  const uint64_t common = 0x123456789abcdefull;
  std::vector<uint64_t> hashes = RandomHashes(rng, 3000, 1);
  // 40 documents each holding the common descriptor once, plus 3000 random ones.
  std::vector<std::vector<uint64_t>> docs(40);
  for (size_t d = 0; d < docs.size(); ++d) {
    docs[d] = {common};
    for (size_t i = d; i < hashes.size(); i += docs.size()) docs[d].push_back(hashes[i]);
  }
  std::vector<InvertedIndex::Batch> batch;
  for (size_t d = 0; d < 20; ++d) batch.push_back({static_cast<uint32_t>(d), &docs[d]});
  index.AddBatch(batch, 1);
  for (size_t d = 20; d < docs.size(); ++d) index.Add(static_cast<uint32_t>(d), docs[d], 1);

  EXPECT_TRUE(index.LikelyExceeds(common, 39));
  EXPECT_FALSE(index.LikelyExceeds(common, 45)) << "overestimates by more than a few";
  // A descriptor with one entry is never a stop word at any limit >= 1, and the sketch
  // never reports fewer entries than there are.
  for (uint64_t h : hashes) {
    ASSERT_FALSE(index.LikelyExceeds(h, 8));
    ASSERT_TRUE(index.LikelyExceeds(h, 0));
  }
  for (size_t d = 0; d < 30; ++d) index.Remove(static_cast<uint32_t>(d), docs[d], 1);
  EXPECT_EQ(index.Count(common, 100), 10);
  EXPECT_TRUE(index.LikelyExceeds(common, 9));
  EXPECT_FALSE(index.LikelyExceeds(common, 15));
}

}  // namespace
}  // namespace texfree
