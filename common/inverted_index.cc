// InvertedIndex implementation.
#include "common/inverted_index.h"

#include <algorithm>
#include <functional>
#include <stdexcept>
#include <thread>
#include <utility>

namespace texfree {

InvertedIndex::InvertedIndex(int log2_buckets)
    : shift_(64 - log2_buckets),
      heads_(size_t{1} << log2_buckets, kNil),
      sketch_bits_(log2_buckets),
      sketch_(size_t{2} << log2_buckets, 0) {}

int InvertedIndex::Log2BucketsFor(size_t entries, int min_log2_buckets) {
  int log2 = min_log2_buckets;
  while (log2 < kMaxLog2Buckets && (size_t{1} << log2) * kEntriesPerBucket < entries) ++log2;
  return log2;
}

bool InvertedIndex::Rebucket(int log2_buckets) {
  if (pool_.size() != 0) return false;
  shift_ = 64 - log2_buckets;
  heads_.assign(size_t{1} << log2_buckets, kNil);
  heads_.shrink_to_fit();
  sketch_bits_ = log2_buckets;
  sketch_.assign(size_t{2} << log2_buckets, 0);
  sketch_.shrink_to_fit();
  return true;
}

size_t InvertedIndex::SketchSlot(uint64_t hash, int row) const {
  // Multiply-shift with two odd constants: two counters per hash, independent of the bucket
  // (top bits) and of the check (low bits).
  static constexpr uint64_t kMix[2] = {0x9E3779B97F4A7C15ull, 0xC2B2AE3D27D4EB4Full};
  return (static_cast<size_t>(row) << sketch_bits_) +
         static_cast<size_t>((hash * kMix[row]) >> (64 - sketch_bits_));
}

int InvertedIndex::SketchCount(uint64_t hash) const {
  return std::min(sketch_[SketchSlot(hash, 0)], sketch_[SketchSlot(hash, 1)]);
}

void InvertedIndex::SketchAdd(uint64_t hash, int delta) {
  for (int row = 0; row < 2; ++row) SketchAddToRow(hash, row, delta);
}

void InvertedIndex::SketchAddToRow(uint64_t hash, int row, int delta) {
  uint16_t& c = sketch_[SketchSlot(hash, row)];
  if (c == 0xFFFF) return;  // saturated: stays an upper bound
  c = static_cast<uint16_t>(c + delta);
}

uint32_t InvertedIndex::Allocate() {
  if (free_ != kNil) {
    const uint32_t e = free_;
    free_ = pool_[e].next;
    return e;
  }
  if (pool_.size() >= kNil - 1) throw std::length_error("inverted index is full (4G entries)");
  pool_.resize(pool_.size() + 1);
  return static_cast<uint32_t>(pool_.size() - 1);
}

void InvertedIndex::Add(uint32_t document, const std::vector<uint64_t>& hashes, int per_point) {
  for (size_t i = 0; i < hashes.size(); ++i) {
    const uint64_t h = hashes[i];
    if (h == 0) continue;
    const uint32_t e = Allocate();
    const size_t b = Bucket(h);
    pool_[e] = {document, static_cast<uint16_t>(i / per_point), Check(h), heads_[b]};
    heads_[b] = e;
    SketchAdd(h, 1);
    ++live_;
  }
}

void InvertedIndex::AddBatch(const std::vector<Batch>& batch, int per_point, int threads) {
  // Counting sort of the new entries by bucket. Each thread owns a range of buckets (their
  // counts, their runs in the pool, their heads) and one sketch row, and reads every hash.
  threads = std::clamp(threads, 1, 8);
  const size_t buckets = heads_.size();
  auto in_parallel = [](int count, const std::function<void(int)>& task) {
    std::vector<std::thread> pool;
    for (int t = 1; t < count; ++t) pool.emplace_back(task, t);
    task(0);
    for (auto& t : pool) t.join();
  };
  auto range = [&](int t) {
    return std::pair<size_t, size_t>{buckets * t / threads, buckets * (t + 1) / threads};
  };
  // Visits every non-zero hash whose key(hash) lies in [lo, hi) as visit(hash, document,
  // keypoint), grouped: a chunk of documents at a time, by partitions of 2^kPartitionBits
  // keys, in batch order within a partition. Counters, pool runs and sketch counters
  // indexed by the key are then written a few hundred kilobytes at a time instead of at
  // random over the whole table: each write was a cache and TLB miss, and at 10,000 pages
  // (64 million entries) those misses were most of the start-up.
  auto grouped = [&](size_t lo, size_t hi, auto key, auto visit) {
    constexpr int kPartitionBits = 12;
    constexpr size_t kChunkHashes = size_t{2} << 20;  // 32 MiB of Pending
    struct Pending {
      uint64_t hash;
      uint32_t document;
      uint32_t keypoint;
    };
    const size_t partitions = ((hi - lo) >> kPartitionBits) + 1;
    std::vector<size_t> fill(partitions + 1);
    std::vector<Pending> pending;
    for (size_t d0 = 0; d0 < batch.size();) {
      size_t d1 = d0, hashes_in_chunk = 0;
      while (d1 < batch.size() &&
             (d1 == d0 || hashes_in_chunk + batch[d1].hashes->size() <= kChunkHashes))
        hashes_in_chunk += batch[d1++].hashes->size();
      std::fill(fill.begin(), fill.end(), 0);
      for (size_t d = d0; d < d1; ++d)
        for (uint64_t h : *batch[d].hashes) {
          const size_t k = key(h);
          if (h != 0 && k >= lo && k < hi) ++fill[((k - lo) >> kPartitionBits) + 1];
        }
      for (size_t p = 1; p <= partitions; ++p) fill[p] += fill[p - 1];
      pending.resize(fill[partitions]);
      for (size_t d = d0; d < d1; ++d) {
        const std::vector<uint64_t>& hashes = *batch[d].hashes;
        for (size_t i = 0; i < hashes.size(); ++i) {
          const uint64_t h = hashes[i];
          const size_t k = key(h);
          if (h == 0 || k < lo || k >= hi) continue;
          pending[fill[(k - lo) >> kPartitionBits]++] = {h, batch[d].document,
                                                         static_cast<uint32_t>(i / per_point)};
        }
      }
      for (const Pending& e : pending) visit(e.hash, e.document, e.keypoint);
      d0 = d1;
    }
  };
  const auto bucket_of = [this](uint64_t h) { return Bucket(h); };
  std::vector<uint32_t> cursor(buckets, 0);
  in_parallel(threads, [&](int t) {
    const auto [lo, hi] = range(t);
    grouped(lo, hi, bucket_of, [&](uint64_t h, uint32_t, uint32_t) { ++cursor[Bucket(h)]; });
  });
  size_t total = 0;  // exclusive prefix sums: where each bucket's run starts
  for (uint32_t& c : cursor) {
    const uint32_t n = c;
    c = static_cast<uint32_t>(total);
    total += n;
  }
  if (total == 0) return;
  const size_t base = pool_.size();
  if (base + total >= kNil) throw std::length_error("inverted index is full (4G entries)");
  pool_.resize(base + total);
  in_parallel(threads, [&](int t) {
    const auto [lo, hi] = range(t);
    const uint32_t first = cursor[lo];  // where the range's first run starts
    grouped(lo, hi, bucket_of, [&](uint64_t h, uint32_t document, uint32_t keypoint) {
      pool_[base + cursor[Bucket(h)]++] = {document, static_cast<uint16_t>(keypoint), Check(h),
                                           kNil};
    });
    // cursor[b] is now the end of bucket b's run; link each run, then the older chain.
    uint32_t begin = first;
    for (size_t b = lo; b < hi; ++b) {
      const uint32_t end = cursor[b];
      if (end == begin) continue;
      for (uint32_t e = begin; e + 1 < end; ++e)
        pool_[base + e].next = static_cast<uint32_t>(base + e + 1);
      pool_[base + end - 1].next = heads_[b];
      heads_[b] = static_cast<uint32_t>(base + begin);
      begin = end;
    }
  });
  // The sketch's two rows are disjoint: one thread each (one thread: both in turn).
  const int sketch_threads = std::min(threads, 2);
  const size_t row_size = size_t{1} << sketch_bits_;
  in_parallel(sketch_threads, [&](int t) {
    for (int row = t; row < 2; row += sketch_threads) {
      const size_t row_base = static_cast<size_t>(row) << sketch_bits_;
      grouped(
          0, row_size, [&](uint64_t h) { return SketchSlot(h, row) - row_base; },
          [&](uint64_t h, uint32_t, uint32_t) { SketchAddToRow(h, row, 1); });
    }
  });
  live_ += total;
}

bool InvertedIndex::AddIfAbsent(uint64_t hash, uint32_t document, uint16_t keypoint) {
  if (hash == 0) return false;
  const size_t b = Bucket(hash);
  for (uint32_t e = heads_[b]; e != kNil; e = pool_[e].next) {
    const Entry& x = pool_[e];
    if (x.check == Check(hash) && x.document == document && x.keypoint == keypoint) return false;
  }
  const uint32_t e = Allocate();
  pool_[e] = {document, keypoint, Check(hash), heads_[b]};
  heads_[b] = e;
  SketchAdd(hash, 1);
  ++live_;
  return true;
}

size_t InvertedIndex::Remove(uint32_t document, const std::vector<uint64_t>& hashes,
                             int per_point) {
  size_t removed = 0;
  for (size_t i = 0; i < hashes.size(); ++i) {
    const uint64_t h = hashes[i];
    if (h == 0) continue;
    const uint16_t kp = static_cast<uint16_t>(i / per_point);
    uint32_t* link = &heads_[Bucket(h)];
    while (*link != kNil) {
      Entry& x = pool_[*link];
      if (x.document == document && x.keypoint == kp && x.check == Check(h)) {
        const uint32_t e = *link;
        *link = x.next;
        pool_[e].next = free_;
        free_ = e;
        SketchAdd(h, -1);
        --live_;
        ++removed;
        break;  // Add() made exactly one entry per hash slot
      }
      link = &x.next;
    }
  }
  return removed;
}

int InvertedIndex::Count(uint64_t hash, int limit) const {
  int n = 0;
  for (uint32_t e = heads_[Bucket(hash)]; e != kNil && n < limit; e = pool_[e].next) {
    if (pool_[e].check == Check(hash)) ++n;
  }
  return n;
}

size_t InvertedIndex::MemoryBytes() const {
  return heads_.capacity() * sizeof(uint32_t) + pool_.capacity() * sizeof(Entry) +
         sketch_.capacity() * sizeof(uint16_t);
}

}  // namespace texfree
