// SessionIndex: the private LLAH index of one tracking session (seed 3.1.4). It holds the
// reference descriptors of the documents the session follows, computed from their
// registered keypoints, plus the descriptors the session learned on-line: frame keypoints
// that took a reference keypoint's id by projection add their freshly computed hashes
// where the slot is empty for that keypoint.
//
// The shared document index (LlahRetriever) is never written by a session, so what one
// user's camera learns can never show up in another user's results. Learned entries are
// bounded: when the budget is full the oldest half is forgotten (the views the camera
// left longest ago), which keeps memory fixed however long the session runs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <unordered_map>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "common/inverted_index.h"

namespace texfree {

struct SessionIndexOptions {
  // Hash table heads: 2^log2_buckets x 4 bytes (512 KiB at 17).
  int log2_buckets = 17;
  // Learned entries kept at most (12 bytes each in the index plus 16 in the history).
  size_t max_learned_entries = 60000;

  absl::Status Validate() const;
};

// Not thread-safe: one session, one thread at a time.
class SessionIndex {
 public:
  explicit SessionIndex(SessionIndexOptions options = {});

  // Adds a document's reference descriptors; hashes are laid out as
  // LlahDescriber::Describe (hashes[i * per_point + j] belongs to keypoint i). Replaces
  // what the document had (reference and learned).
  void AddDocument(uint32_t document, std::vector<uint64_t> hashes, int per_point);
  // Forgets a document: reference and learned entries.
  void RemoveDocument(uint32_t document);
  bool Contains(uint32_t document) const { return documents_.count(document) > 0; }

  // On-line learning: adds hash -> (document, keypoint) unless that keypoint already sits
  // under this descriptor. Returns true when added. Ignored for unknown documents.
  bool Learn(uint64_t hash, uint32_t document, uint16_t keypoint);

  // Calls f(document, keypoint) for each entry under the hash.
  template <typename F>
  void ForEach(uint64_t hash, F&& f) const {
    index_->ForEach(hash, std::forward<F>(f));
  }
  int Count(uint64_t hash, int limit) const { return index_->Count(hash, limit); }

  size_t learned_entries() const { return learned_.size(); }
  size_t learned_entries(uint32_t document) const;
  size_t entries() const { return index_->entries(); }
  size_t MemoryBytes() const;
  const SessionIndexOptions& options() const { return options_; }

 private:
  struct Learned {
    uint64_t hash;
    uint32_t document;
    uint16_t keypoint;
  };
  struct Reference {
    std::vector<uint64_t> hashes;
    int per_point = 1;
    size_t learned = 0;
  };
  // Re-creates the index from the references and the learned history (after a removal
  // or when forgetting the oldest learned entries).
  void Rebuild();

  SessionIndexOptions options_;
  std::unique_ptr<InvertedIndex> index_;
  std::unordered_map<uint32_t, Reference> documents_;
  std::deque<Learned> learned_;  // oldest first
};

}  // namespace texfree
