#pragma once
/// \file op/row.hpp
/// \brief Two RowBuilder models (op/concepts.hpp): `row_value` evaluates a row on a field (explicit
/// application), `row_entries` records it as sorted, merged (column, value) pairs plus diagonal and
/// constant (implicit assembly). Both receive the same calls, so application and assembly share one
/// code path (ARCHITECTURE.md §4).
#include <Eigen/Core>
#include <algorithm>
#include <utility>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/op/concepts.hpp"

namespace mpskit::op {

/// Evaluates Σ_j a_j φ_j + a_diag φ_i + c on a field φ, accumulating in call order.
class row_value final {
 public:
  /// φ must outlive the builder; i is the row particle.
  row_value(const Eigen::Ref<const Eigen::VectorXd>& phi, index_t i) : phi_(phi), i_(i) {}
  void add(index_t j, double a) { sum_ += a * phi_[j]; }  ///< a·φ_j
  void add_diagonal(double a) { diag_ += a; }             ///< a·φ_i
  void add_constant(double c) { constant_ += c; }         ///< c
  /// The row's value.
  double value() const { return sum_ + diag_ * phi_[i_] + constant_; }
  double constant() const { return constant_; }  ///< the constant part alone

 private:
  Eigen::Ref<const Eigen::VectorXd> phi_;
  index_t i_;
  double sum_ = 0.0, diag_ = 0.0, constant_ = 0.0;
};

/// Records a row: off-diagonal (column, value) pairs, the diagonal and the constant.
class row_entries final {
 public:
  /// i is the row particle (a column j == i is folded into the diagonal).
  explicit row_entries(index_t i = npos) : i_(i) {}
  void add(index_t j, double a) {  ///< a·φ_j
    if (j == i_)
      diag_ += a;
    else
      cols_.emplace_back(j, a);
  }
  void add_diagonal(double a) { diag_ += a; }      ///< a·φ_i
  void add_constant(double c) { constant_ += c; }  ///< c
  /// Sorts by column and sums repeated columns (stable: repeated entries are summed in call order).
  void merge() {
    const auto by_column = [](const auto& a, const auto& b) { return a.first < b.first; };
    // Short rows (a 2D PPE row has a few dozen entries) by insertion sort, which is stable too: the same
    // order as std::stable_sort, without its temporary buffer (an allocation per row). Perf of the
    // multires_hard dam break, 2026-12-06: the sort and merge 3.6 % of the run before, 2.5 % after. Longer
    // rows (3D, about 125 neighbours) keep std::stable_sort.
    if (cols_.size() <= 64) {
      for (std::size_t k = 1; k < cols_.size(); ++k) {
        const auto e = cols_[k];
        std::size_t m = k;
        for (; m > 0 && by_column(e, cols_[m - 1]); --m) cols_[m] = cols_[m - 1];
        cols_[m] = e;
      }
    } else {
      std::stable_sort(cols_.begin(), cols_.end(), by_column);
    }
    std::size_t out = 0;
    for (std::size_t k = 0; k < cols_.size(); ++k) {
      if (out > 0 && cols_[out - 1].first == cols_[k].first)
        cols_[out - 1].second += cols_[k].second;
      else
        cols_[out++] = cols_[k];
    }
    cols_.resize(out);
  }
  /// Clears for row i (keeps capacity).
  void reset(index_t i) {
    i_ = i;
    cols_.clear();
    diag_ = constant_ = 0.0;
  }
  const std::vector<std::pair<index_t, double>>& columns() const { return cols_; }  ///< off-diagonal entries
  double diagonal() const { return diag_; }                                         ///< coefficient of φ_i
  double constant() const { return constant_; }                                     ///< known term
  index_t row() const { return i_; }                                                ///< the row particle
  /// Σ a_j φ_j + a_diag φ_i + c.
  double apply(const Eigen::Ref<const Eigen::VectorXd>& phi) const {
    double s = 0.0;
    for (const auto& [j, a] : cols_) s += a * phi[j];
    return s + diag_ * phi[i_] + constant_;
  }

 private:
  index_t i_;
  std::vector<std::pair<index_t, double>> cols_;
  double diag_ = 0.0, constant_ = 0.0;
};

static_assert(RowBuilder<row_value> && RowBuilder<row_entries>);

}  // namespace mpskit::op
