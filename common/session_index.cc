// SessionIndex implementation.
#include "common/session_index.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace texfree {

absl::Status SessionIndexOptions::Validate() const {
  if (log2_buckets < 8 || log2_buckets > 24)
    return absl::InvalidArgumentError(
        absl::StrCat("session index log2_buckets must be in [8, 24], got ", log2_buckets));
  if (max_learned_entries > 10'000'000)
    return absl::InvalidArgumentError(absl::StrCat(
        "max_learned_entries must be at most 10000000, got ", max_learned_entries));
  return absl::OkStatus();
}

SessionIndex::SessionIndex(SessionIndexOptions options)
    : options_(options), index_(std::make_unique<InvertedIndex>(options.log2_buckets)) {}

void SessionIndex::AddDocument(uint32_t document, std::vector<uint64_t> hashes, int per_point) {
  if (documents_.count(document)) RemoveDocument(document);
  index_->Add(document, hashes, per_point);
  documents_[document] = Reference{std::move(hashes), per_point, 0};
}

void SessionIndex::RemoveDocument(uint32_t document) {
  if (!documents_.erase(document)) return;
  learned_.erase(std::remove_if(learned_.begin(), learned_.end(),
                                [&](const Learned& l) { return l.document == document; }),
                 learned_.end());
  Rebuild();
}

bool SessionIndex::Learn(uint64_t hash, uint32_t document, uint16_t keypoint) {
  auto it = documents_.find(document);
  if (it == documents_.end() || options_.max_learned_entries == 0) return false;
  if (learned_.size() >= options_.max_learned_entries) {
    // Forget the oldest half in one go: a rebuild per entry would cost O(entries) each.
    const size_t keep = options_.max_learned_entries / 2;
    learned_.erase(learned_.begin(), learned_.end() - static_cast<std::ptrdiff_t>(keep));
    Rebuild();
  }
  if (!index_->AddIfAbsent(hash, document, keypoint)) return false;
  learned_.push_back({hash, document, keypoint});
  ++documents_[document].learned;
  return true;
}

size_t SessionIndex::learned_entries(uint32_t document) const {
  auto it = documents_.find(document);
  return it == documents_.end() ? 0 : it->second.learned;
}

size_t SessionIndex::MemoryBytes() const {
  size_t bytes = index_->MemoryBytes() + learned_.size() * sizeof(Learned);
  for (const auto& [id, ref] : documents_) bytes += ref.hashes.capacity() * sizeof(uint64_t);
  return bytes;
}

void SessionIndex::Rebuild() {
  auto index = std::make_unique<InvertedIndex>(options_.log2_buckets);
  size_t total = learned_.size();
  for (auto& [id, ref] : documents_) {
    total += ref.hashes.size();
    ref.learned = 0;
  }
  index->Reserve(total);
  for (const auto& [id, ref] : documents_) index->Add(id, ref.hashes, ref.per_point);
  std::deque<Learned> kept;
  for (const Learned& l : learned_) {
    if (index->AddIfAbsent(l.hash, l.document, l.keypoint)) {
      kept.push_back(l);
      ++documents_[l.document].learned;
    }
  }
  learned_ = std::move(kept);
  index_ = std::move(index);
}

}  // namespace texfree
