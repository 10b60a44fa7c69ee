// InvertedIndex: LLAH hash table from descriptor to (document, keypoint) entries.
//
// Buckets are heads of singly linked lists threaded through one pooled entry array, so
// memory is proportional to the number of entries (12 bytes each), not to documents x
// H_size; a deleted document's entries go to a free list and are reused. Each entry keeps
// 16 bits of the descriptor hash beyond the bucket number, which rejects almost every
// collision between different descriptors sharing a bucket.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace texfree {

// Not thread-safe: callers serialise writers against readers (LlahRetriever does).
class InvertedIndex {
 public:
  // 2^log2_buckets list heads (4 bytes each).
  explicit InvertedIndex(int log2_buckets = 22);

  // Adds an entry for every non-zero hash; hashes[i * per_point + j] belongs to keypoint i.
  void Add(uint32_t document, const std::vector<uint64_t>& hashes, int per_point);

  // Adds many documents at once (start-up): the same entries as Add() for each, but laid out
  // bucket by bucket so that walking a chain reads consecutive memory instead of jumping
  // across the pool (common descriptors have hundreds of entries at 10,000 pages).
  struct Batch {
    uint32_t document;
    const std::vector<uint64_t>* hashes;
  };
  // `threads` share the work (each owns a range of buckets); the result is the same.
  void AddBatch(const std::vector<Batch>& batch, int per_point, int threads = 1);

  // Adds one entry unless this (document, keypoint) already sits under that descriptor.
  // Returns true when added.
  bool AddIfAbsent(uint64_t hash, uint32_t document, uint16_t keypoint);

  // Removes the entries Add() made for these hashes. Returns how many were removed.
  size_t Remove(uint32_t document, const std::vector<uint64_t>& hashes, int per_point);

  // Calls f(document, keypoint) for each entry whose full hash check matches.
  template <typename F>
  void ForEach(uint64_t hash, F&& f) const {
    for (uint32_t e = heads_[Bucket(hash)]; e != kNil; e = pool_[e].next) {
      const Entry& entry = pool_[e];
      if (entry.check == Check(hash)) f(entry.document, entry.keypoint);
    }
  }

  // One walk of the chain: calls f(document, keypoint) for the entries of `hash` and returns
  // their number, or stops and returns limit + 1 as soon as there are more than `limit`
  // (f has then been called for the first `limit` only; callers discard those).
  template <typename F>
  int ForEachUpTo(uint64_t hash, int limit, F&& f) const {
    int n = 0;
    for (uint32_t e = heads_[Bucket(hash)]; e != kNil; e = pool_[e].next) {
      const Entry& entry = pool_[e];
      if (entry.check != Check(hash)) continue;
      if (++n > limit) return n;
      f(entry.document, entry.keypoint);
    }
    return n;
  }

  // Number of entries under a hash (with the check), stopping at `limit`.
  int Count(uint64_t hash, int limit) const;

  // True when the hash certainly or almost certainly has more than `limit` entries, told
  // without walking its chain: a count-min sketch (two rows of 2^log2_buckets saturating
  // counters) bounds every hash's count from above, overestimating by the few entries of
  // other hashes that share both its counters. Stop-word tests use it, because walking a
  // common descriptor's hundreds of entries only to discard them was most of a query's
  // lookup time at 10,000 pages; a hash within a few entries of the limit may be called a
  // stop word too.
  bool LikelyExceeds(uint64_t hash, int limit) const { return SketchCount(hash) > limit; }

  // Pre-allocates room for `entries` entries (start-up rebuild knows the total).
  void Reserve(size_t entries) { pool_.reserve(entries); }

  // The table size for `entries` entries: chains of about kEntriesPerBucket at most (walking
  // a chain is a cache miss an entry for entries added one by one), never below
  // `min_log2_buckets`, at most kMaxLog2Buckets (1 GiB of heads and sketch).
  static constexpr size_t kEntriesPerBucket = 16;
  static constexpr int kMaxLog2Buckets = 27;
  static int Log2BucketsFor(size_t entries, int min_log2_buckets);
  // Another table size; only while the index is empty (false otherwise).
  bool Rebucket(int log2_buckets);
  int log2_buckets() const { return 64 - shift_; }

  size_t entries() const { return live_; }
  size_t MemoryBytes() const;

 private:
  struct Entry {
    uint32_t document;
    uint16_t keypoint;
    uint16_t check;
    uint32_t next;
  };
  static constexpr uint32_t kNil = 0xFFFFFFFFu;

  // The entries, in blocks of 2^16 (768 KiB) that never move: growing a single array by
  // doubling would copy it and, for a moment, hold it twice (at 100,000 pages the pool is
  // about 9 GB). Small indexes (a tracking stream's) take one block.
  class EntryPool {
   public:
    Entry& operator[](uint32_t e) { return blocks_[e >> kBlockBits][e & kBlockMask]; }
    const Entry& operator[](uint32_t e) const { return blocks_[e >> kBlockBits][e & kBlockMask]; }
    size_t size() const { return size_; }
    size_t capacity() const { return blocks_.size() << kBlockBits; }
    // Room for n entries without moving any.
    void reserve(size_t n) {
      while (capacity() < n) blocks_.push_back(std::make_unique<Entry[]>(size_t{1} << kBlockBits));
    }
    void resize(size_t n) {
      reserve(n);
      size_ = n;
    }

   private:
    static constexpr int kBlockBits = 16;
    static constexpr uint32_t kBlockMask = (1u << kBlockBits) - 1;
    std::vector<std::unique_ptr<Entry[]>> blocks_;
    size_t size_ = 0;
  };

  size_t Bucket(uint64_t hash) const { return static_cast<size_t>(hash >> shift_); }
  static uint16_t Check(uint64_t hash) { return static_cast<uint16_t>(hash & 0xFFFF); }
  uint32_t Allocate();
  size_t SketchSlot(uint64_t hash, int row) const;
  int SketchCount(uint64_t hash) const;
  void SketchAdd(uint64_t hash, int delta);
  void SketchAddToRow(uint64_t hash, int row, int delta);  // one row (0 or 1) only

  int shift_;
  std::vector<uint32_t> heads_;
  EntryPool pool_;
  int sketch_bits_;
  std::vector<uint16_t> sketch_;  // two rows
  uint32_t free_ = kNil;
  size_t live_ = 0;
};

}  // namespace texfree
