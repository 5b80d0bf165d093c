#pragma once
// Internal: the untangler's gradient summed part by part. The active tets,
// in their (spatial) order, are cut into parts of kPartTets; each part adds
// its tets' corner terms into rows of its own, one row per free vertex it
// touches (numbered as the part first reaches them) and one sink row for
// its corners at vertices that do not move. A free vertex's gradient is
// then the sum of its rows, part by part in order. The parts depend on the
// tets alone, not on the threads, so the sums are the same on any number of
// cores.
//
// It replaces one term slot per corner (CornerTerms, spd_solver.h), which
// the energy's loop wrote and the per-vertex loop read back: 96 bytes a tet
// each way through a buffer of a hundred megabytes on bunny00, where a
// part's rows (a few thousand) stay in the core's cache between its tets.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdlib>
#include <memory>
#include <new>
#include <vector>

#include "untangle_energy.h"

namespace tet2spline::detail {

class PartGradients {
 public:
  /// Active tets per part: small enough for a part's rows to stay in a
  /// core's cache, many parts for both cores to share.
  static constexpr size_t kPartTets = 8192;
  /// Doubles per row: x, y, z and an unused zero (one aligned 32-byte block).
  static constexpr size_t kStride = 4;

  /// tetVertices: the active tets' four vertices; freeIndex[v]: v's index
  /// among the free vertices (0 .. numFree − 1), or −1 if v does not move.
  PartGradients(const std::vector<std::array<int, 4>>& tetVertices, const std::vector<int>& freeIndex, size_t numFree)
      : tets_(tetVertices.size()), rows_(4 * tetVertices.size()), entryStart_(numFree + 1, 0) {
    const size_t numParts = (tets_ + kPartTets - 1) / kPartTets;
    partRow_.assign(numParts + 1, 0);
    std::vector<int> stamp(numFree, -1), local(numFree, 0);
    std::vector<std::array<int, 2>> entries;  // (free index, row), parts in order
    entries.reserve(numFree + numFree / 2);
    int row = 0;
    for (size_t p = 0; p < numParts; ++p) {
      const size_t end = std::min(tets_, (p + 1) * kPartTets);
      for (size_t a = p * kPartTets; a < end; ++a)
        for (int k = 0; k < 4; ++k) {
          const int f = freeIndex[static_cast<size_t>(tetVertices[a][k])];
          int& r = rows_[4 * a + static_cast<size_t>(k)];
          if (f < 0) {
            r = -1;  // (the sink, once the part's rows are counted)
            continue;
          }
          if (stamp[static_cast<size_t>(f)] != static_cast<int>(p)) {
            stamp[static_cast<size_t>(f)] = static_cast<int>(p);
            local[static_cast<size_t>(f)] = row;
            entries.push_back({f, row++});
          }
          r = local[static_cast<size_t>(f)];
        }
      const int sink = row++;
      for (size_t c = 4 * p * kPartTets; c < 4 * end; ++c)
        if (rows_[c] < 0) rows_[c] = sink;
      partRow_[p + 1] = row;
    }
    // Each free vertex's rows, in part order (a stable counting sort).
    for (const auto& e : entries) ++entryStart_[static_cast<size_t>(e[0]) + 1];
    for (size_t f = 0; f < numFree; ++f) entryStart_[f + 1] += entryStart_[f];
    entryRow_.resize(entries.size());
    std::vector<int> fill(entryStart_.begin(), entryStart_.end() - 1);
    for (const auto& e : entries) entryRow_[static_cast<size_t>(fill[static_cast<size_t>(e[0])]++)] = e[1];
    const size_t bytes = std::max<size_t>(64, (kStride * sizeof(double) * static_cast<size_t>(row) + 63) / 64 * 64);
    acc_.reset(static_cast<double*>(std::aligned_alloc(64, bytes)));
    if (!acc_) throw std::bad_alloc();
  }

  size_t parts() const { return partRow_.size() - 1; }
  size_t partBegin(size_t p) const { return p * kPartTets; }
  size_t partEnd(size_t p) const { return std::min(tets_, (p + 1) * kPartTets); }
  /// Per active tet, its four corners' rows (indices of kStride-double blocks of data()).
  const int* rows() const { return rows_.data(); }
  /// The rows: kStride doubles each, 64-byte aligned.
  double* data() { return acc_.get(); }
  /// Rows of all parts.
  size_t numRows() const { return static_cast<size_t>(partRow_.back()); }
  /// Sets part p's rows to zero (before its tets add their terms).
  void zero(size_t p) {
    std::fill(acc_.get() + kStride * static_cast<size_t>(partRow_[p]), acc_.get() + kStride * static_cast<size_t>(partRow_[p + 1]),
              0.0);
  }
  /// Adds active tet a's corner terms (cornerTerms, untangle_energy.h) to
  /// its corners' rows, corner after corner; untangle_kernel.h's loop does
  /// the same operations.
  void addProduct(size_t a, double w, const Eigen::Matrix3d& A, const Eigen::Matrix<double, 3, 4>& G) {
    double term[4][3];
    cornerTerms(w, A, G, term);
    for (int k = 0; k < 4; ++k) {
      double* out = acc_.get() + kStride * static_cast<size_t>(rows_[4 * a + static_cast<size_t>(k)]);
      for (int d = 0; d < 3; ++d) out[d] += term[k][d];
    }
  }
  /// Adds free vertex f's rows to s, part by part in order.
  void addTo(size_t f, Eigen::Vector3d& s) const {
    for (int e = entryStart_[f]; e < entryStart_[f + 1]; ++e)
      s += Eigen::Map<const Eigen::Vector3d>(acc_.get() + kStride * static_cast<size_t>(entryRow_[static_cast<size_t>(e)]));
  }

 private:
  struct Free {
    void operator()(double* p) const { std::free(p); }
  };
  size_t tets_;
  std::vector<int> rows_;       // 4 per active tet
  std::vector<int> partRow_;    // part p's rows: partRow_[p] .. partRow_[p + 1] − 1 (the last its sink)
  std::vector<int> entryStart_;  // free vertex f's rows: entryRow_[entryStart_[f] .. entryStart_[f + 1])
  std::vector<int> entryRow_;
  std::unique_ptr<double[], Free> acc_;
};

}  // namespace tet2spline::detail
