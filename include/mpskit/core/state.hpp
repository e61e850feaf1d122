#pragma once
/// \file core/state.hpp
/// \brief particle_state<D, Fields>: structure of arrays holding exactly the core fields plus the union
/// of what a scene's policies ask for, a ghost range after the real particles, persistent ids, and the
/// one permutation/resize path (ARCHITECTURE.md §3).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string_view>
#include <tuple>
#include <vector>

#include "mpskit/core/dimension.hpp"
#include "mpskit/core/error.hpp"
#include "mpskit/core/fields.hpp"
#include "mpskit/core/kinds.hpp"

namespace mpskit {

/// What one call of the resize path did (every change of order or count is reported).
struct resize_report {
  index_t old_size = 0;         ///< particles (real + ghost) before
  index_t new_size = 0;         ///< particles (real + ghost) after
  index_t reordered = 0;        ///< real particles that changed slot
  index_t appended = 0;         ///< new real particles (new ids)
  index_t removed = 0;          ///< real particles removed
  index_t promoted = 0;         ///< ghosts that became real particles (new ids)
  index_t ghosts_added = 0;     ///< ghosts appended
  index_t ghosts_cleared = 0;   ///< ghosts dropped
  index_t references_lost = 0;  ///< index-holding field entries that pointed at a removed particle (now npos)
  /// new slot of each old slot, npos if gone; remap external indices with it
  std::vector<index_t> old_to_new;
  /// New index of an old index (npos stays npos).
  index_t remap(index_t old) const {
    return old < 0 ? npos : old_to_new[static_cast<std::size_t>(old)];
  }
};

template <int D, class Fields = field_list<>>
class particle_state;

/// particle_state over core_fields ∪ Fields. Real particles occupy [0, n_real()), ghosts
/// [n_real(), size()). Fields hold one entry per particle, ghosts included.
template <int D, FieldTag... Extra>
  requires Dimension<D>
class particle_state<D, field_list<Extra...>> {
 public:
  using fields = field_union<core_fields, field_list<Extra...>>;
  static constexpr int dim = D;

  particle_state() { resize_all(0); }
  /// A state with n real fluid particles at rest at the origin (fill positions afterwards).
  explicit particle_state(index_t n) {
    append(n, kind::fluid);
  }

  /// Number of real plus ghost particles.
  index_t size() const { return n_total_; }
  /// Number of real particles.
  index_t n_real() const { return n_real_; }
  /// Number of ghosts.
  index_t n_ghost() const { return n_total_ - n_real_; }
  /// The id the next new particle gets (ids are never reused).
  particle_id next_id() const { return next_id_; }

  /// True when the state holds field T.
  template <class T>
  static constexpr bool has = contains_v<fields, T>;

  /// Storage of field T; a compile error when the scene has no such field.
  template <class T>
  field_storage_t<T, D>& get() {
    static_assert(has<T>, "mpskit: this state has no such field: add it to a policy's `fields` list");
    return std::get<index_of<T>()>(data_);
  }
  template <class T>
  const field_storage_t<T, D>& get() const {
    static_assert(has<T>, "mpskit: this state has no such field: add it to a policy's `fields` list");
    return std::get<index_of<T>()>(data_);
  }

  points<D>& x() { return get<field::position>(); }                ///< positions
  const points<D>& x() const { return get<field::position>(); }    ///< positions
  points<D>& u() { return get<field::velocity>(); }                ///< velocities
  const points<D>& u() const { return get<field::velocity>(); }    ///< velocities
  const std::vector<particle_id>& ids() const { return get<field::id>(); }  ///< persistent ids
  std::vector<kind>& kinds() { return get<field::kind>(); }        ///< persistent kinds
  const std::vector<kind>& kinds() const { return get<field::kind>(); }
  std::vector<flag::type>& flags() { return get<field::flags>(); }  ///< per-step flag bits
  const std::vector<flag::type>& flags() const { return get<field::flags>(); }

  /// Calls f(tag) for every field tag (for writers, checkpoints, validation).
  template <class F>
  static void for_each_field(F&& f) {
    for_each_tag(f, fields{});
  }

  // ---- the one permutation/resize path ------------------------------------------------------------

  /// Reorders real particles: new slot k holds old particle perm[k]. Ghosts must be cleared first.
  resize_report reorder(const std::vector<index_t>& perm) {
    require_no_ghosts("reorder");
    if (static_cast<index_t>(perm.size()) != n_real_)
      fail("reorder: permutation has ", perm.size(), " entries, the state has ", n_real_, " particles");
    std::vector<char> seen(perm.size(), 0);
    for (std::size_t k = 0; k < perm.size(); ++k) {
      const index_t p = perm[k];
      if (p < 0 || p >= n_real_ || seen[static_cast<std::size_t>(p)])
        fail("reorder: entry ", k, " = ", p, " is out of [0, ", n_real_, ") or repeated: not a permutation");
      seen[static_cast<std::size_t>(p)] = 1;
    }
    return apply(perm, n_real_, 0);
  }

  /// Removes real particles with mask[i] != 0 (stable). Ghosts must be cleared first.
  template <class Mask>
  resize_report remove(const Mask& mask) {
    require_no_ghosts("remove");
    if (static_cast<index_t>(mask.size()) != n_real_)
      fail("remove: mask has ", mask.size(), " entries, the state has ", n_real_, " particles");
    std::vector<index_t> src;
    src.reserve(static_cast<std::size_t>(n_real_));
    for (index_t i = 0; i < n_real_; ++i)
      if (!mask[static_cast<std::size_t>(i)]) src.push_back(i);
    const index_t kept = static_cast<index_t>(src.size());
    return apply(src, kept, 0);
  }

  /// Appends n real particles of kind k (zero fields, new ids); returns the first new index.
  index_t append(index_t n, kind k, resize_report* report = nullptr) {
    require_no_ghosts("append");
    if (n < 0) fail("append: count ", n, " is negative");
    std::vector<index_t> src(static_cast<std::size_t>(n_real_ + n), npos);
    for (index_t i = 0; i < n_real_; ++i) src[static_cast<std::size_t>(i)] = i;
    const index_t first = n_real_;
    resize_report r = apply(src, n_real_ + n, 0);
    for (index_t i = first; i < n_real_; ++i) kinds()[static_cast<std::size_t>(i)] = k;
    if (report) *report = std::move(r);
    return first;
  }

  /// Appends n ghosts with the given role (parents npos; set them); returns the first ghost index.
  index_t add_ghosts(index_t n, ghost_role r, resize_report* report = nullptr) {
    if (n < 0) fail("add_ghosts: count ", n, " is negative");
    if (r == ghost_role::none) fail("add_ghosts: a ghost needs a role other than none");
    std::vector<index_t> src(static_cast<std::size_t>(n_total_ + n), npos);
    for (index_t i = 0; i < n_total_; ++i) src[static_cast<std::size_t>(i)] = i;
    const index_t first = n_total_;
    resize_report rep = apply(src, n_real_, n_total_ - n_real_ + n);
    auto& roles = get<field::role>();
    for (index_t i = first; i < n_total_; ++i) roles[static_cast<std::size_t>(i)] = r;
    if (report) *report = std::move(rep);
    return first;
  }

  /// Drops every ghost (nothing outlives a step in the ghost range).
  resize_report clear_ghosts() {
    std::vector<index_t> src(static_cast<std::size_t>(n_real_));
    for (index_t i = 0; i < n_real_; ++i) src[static_cast<std::size_t>(i)] = i;
    return apply(src, n_real_, 0);
  }

  /// Promotes the listed ghosts to real particles (appended after the real range, in list order, with
  /// new ids, role none, parent npos); all other ghosts are dropped.
  resize_report promote_ghosts(const std::vector<index_t>& ghosts) {
    std::vector<index_t> src(static_cast<std::size_t>(n_real_));
    for (index_t i = 0; i < n_real_; ++i) src[static_cast<std::size_t>(i)] = i;
    std::vector<char> seen(static_cast<std::size_t>(n_total_), 0);
    for (index_t g : ghosts) {
      if (g < n_real_ || g >= n_total_ || seen[static_cast<std::size_t>(g)])
        fail("promote_ghosts: ", g, " is not a ghost index in [", n_real_, ", ", n_total_,
             ") or is repeated");
      seen[static_cast<std::size_t>(g)] = 1;
      src.push_back(g);
    }
    return apply(src, static_cast<index_t>(src.size()), 0);
  }

  /// Rebuilds the real range in one pass (splitting, merging: ARCHITECTURE.md §3) and drops every ghost.
  /// New real slot k takes every field of old real particle src[k]. With born[k] == 0 the slot *is* that
  /// particle moved (an old particle appears at most once this way; old_to_new records it); with born[k] != 0
  /// it is a new particle (fresh id, role none, parent npos) whose fields start as a copy of src[k] (npos:
  /// zero fields), and old_to_new does not point at it. Old real particles kept in no slot are removed.
  resize_report gather(const std::vector<index_t>& src, const std::vector<std::uint8_t>& born) {
    if (born.size() != src.size())
      fail("gather: ", src.size(), " sources but ", born.size(), " born marks");
    std::vector<char> kept(static_cast<std::size_t>(n_real_), 0);
    for (std::size_t k = 0; k < src.size(); ++k) {
      const index_t p = src[k];
      if (p == npos && born[k]) continue;
      if (p < 0 || p >= n_real_)
        fail("gather: entry ", k, " = ", p, " is not a real particle index in [0, ", n_real_, ")");
      if (born[k]) continue;
      if (kept[static_cast<std::size_t>(p)])
        fail("gather: old particle ", p, " is kept in two slots (mark the copies as born)");
      kept[static_cast<std::size_t>(p)] = 1;
    }
    return apply(src, static_cast<index_t>(src.size()), 0, &born);
  }

  /// Sets the layout read back from a checkpoint or output file (io/): every field resized to
  /// n_real + n_ghost entries (the first min(old, new) entries kept, new ones zero), counts and the next
  /// id set. Not a resize path (nothing remapped, no ids given): the caller fills every field, then
  /// validates.
  void restore_layout(index_t n_real, index_t n_ghost, particle_id next_id) {
    if (n_real < 0 || n_ghost < 0)
      fail("restore_layout: counts ", n_real, " real, ", n_ghost, " ghost must be >= 0");
    const index_t m = n_real + n_ghost;
    for_each_field([&](auto tag) {
      using T = decltype(tag);
      auto& s = get<T>();
      const index_t keep = std::min(m, static_cast<index_t>(field_size(s)));
      if constexpr (T::shape == field_shape::vector) {
        points<D> out = points<D>::Zero(D, m);
        out.leftCols(keep) = s.leftCols(keep);
        s = std::move(out);
      } else if constexpr (T::shape == field_shape::scalar) {
        Eigen::VectorXd out = Eigen::VectorXd::Zero(m);
        out.head(keep) = s.head(keep);
        s = std::move(out);
      } else {
        s.resize(static_cast<std::size_t>(m), typename T::value_type{});
      }
    });
    n_real_ = n_real;
    n_total_ = m;
    next_id_ = next_id;
  }

  // ---- validation ------------------------------------------------------------------------------------

  /// Checks every field has size() entries, positions and velocities are finite, ids are unique
  /// among real particles and ghosts have a role; throws mpskit::error naming the field and particle.
  void validate() const {
    for_each_field([&](auto tag) {
      using T = decltype(tag);
      const auto& s = get<T>();
      const index_t n = static_cast<index_t>(field_size(s));
      if (n != n_total_)
        fail("field '", T::name, "' has ", n, " entries, the state has ", n_total_, " particles");
      if constexpr (T::shape == field_shape::scalar || T::shape == field_shape::vector) {
        for (index_t i = 0; i < n_total_; ++i)
          if (!col_finite(s, i))
            fail("field '", T::name, "' of particle ", i, " (id ", id_of(i), ") is not finite (NaN or inf)");
      }
    });
    const auto& roles = get<field::role>();
    for (index_t i = 0; i < n_total_; ++i) {
      const bool ghost = i >= n_real_;
      if (ghost != (roles[static_cast<std::size_t>(i)] != ghost_role::none))
        fail("particle ", i, ": ghost role does not match its range (ghosts are [", n_real_, ", ", n_total_,
             "))");
    }
    std::vector<particle_id> sorted(ids().begin(), ids().begin() + n_real_);
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) fail("particle ids are not unique");
  }

 private:
  using storage_tuple = std::tuple<field_storage_t<Extra, D>...>;
  template <class L>
  struct tuple_of;
  template <class... Ts>
  struct tuple_of<field_list<Ts...>> {
    using type = std::tuple<field_storage_t<Ts, D>...>;
  };

  template <class T, class... Ts>
  static constexpr std::size_t find_index(field_list<Ts...>) {
    std::size_t i = 0, found = sizeof...(Ts);
    ((std::same_as<T, Ts> ? (found = i, ++i) : ++i), ...);
    return found;
  }
  template <class T>
  static constexpr std::size_t index_of() {
    return find_index<T>(fields{});
  }
  template <class F, class... Ts>
  static void for_each_tag(F& f, field_list<Ts...>) {
    (f(Ts{}), ...);
  }

  template <class S>
  static std::size_t field_size(const S& s) {
    if constexpr (requires { s.cols(); } && !std::same_as<S, Eigen::VectorXd>)
      return static_cast<std::size_t>(s.cols());
    else
      return static_cast<std::size_t>(s.size());
  }
  template <class S>
  static bool col_finite(const S& s, index_t i) {
    if constexpr (std::same_as<S, Eigen::VectorXd>)
      return std::isfinite(s[i]);
    else
      return s.col(i).allFinite();
  }
  particle_id id_of(index_t i) const { return ids()[static_cast<std::size_t>(i)]; }

  void require_no_ghosts(const char* what) const {
    if (n_real_ != n_total_)
      fail(what, ": the state holds ", n_total_ - n_real_, " ghosts; clear or promote them first");
  }

  void resize_all(index_t n) {
    for_each_field([&](auto tag) {
      using T = decltype(tag);
      auto& s = get<T>();
      if constexpr (T::shape == field_shape::vector) s.setZero(D, n);
      else if constexpr (T::shape == field_shape::scalar) s.setZero(n);
      else s.assign(static_cast<std::size_t>(n), typename T::value_type{});
    });
    n_total_ = n_real_ = n;
  }

  /// The one path: new slot k takes old slot src[k] (npos: a new particle with zero fields). Slots
  /// [0, n_real) are real, the next n_ghost are ghosts. Index-holding fields are remapped through
  /// old_to_new; new real particles (and promoted ghosts) get fresh ids.
  /// born (gather only): slots that are new particles copied from src[k] (fresh ids, not in old_to_new).
  resize_report apply(const std::vector<index_t>& src, index_t n_real, index_t n_ghost,
                      const std::vector<std::uint8_t>* born = nullptr) {
    const auto is_born = [born](index_t k) { return born && (*born)[static_cast<std::size_t>(k)] != 0; };
    resize_report rep;
    rep.old_size = n_total_;
    const index_t m = n_real + n_ghost;
    MPSKIT_ASSERT(static_cast<index_t>(src.size()) == m);
    rep.new_size = m;
    rep.old_to_new.assign(static_cast<std::size_t>(n_total_), npos);
    for (index_t k = 0; k < m; ++k) {
      const index_t s = src[static_cast<std::size_t>(k)];
      if (s >= 0 && !is_born(k)) rep.old_to_new[static_cast<std::size_t>(s)] = k;
      if (k < n_real) {
        if (s < 0 || is_born(k)) ++rep.appended;
        else if (s >= n_real_) ++rep.promoted;
        else if (s != k) ++rep.reordered;
      } else if (s < 0) {
        ++rep.ghosts_added;
      }
    }
    for (index_t i = 0; i < n_total_; ++i) {
      if (rep.old_to_new[static_cast<std::size_t>(i)] != npos) continue;
      if (i < n_real_) ++rep.removed;
      else ++rep.ghosts_cleared;
    }
    for_each_field([&](auto tag) {
      using T = decltype(tag);
      auto& s = get<T>();
      field_storage_t<T, D> out;
      if constexpr (T::shape == field_shape::vector) {
        out.setZero(D, m);
        for (index_t k = 0; k < m; ++k)
          if (const index_t j = src[static_cast<std::size_t>(k)]; j >= 0) out.col(k) = s.col(j);
      } else if constexpr (T::shape == field_shape::scalar) {
        out.setZero(m);
        for (index_t k = 0; k < m; ++k)
          if (const index_t j = src[static_cast<std::size_t>(k)]; j >= 0) out[k] = s[j];
      } else {
        using V = typename T::value_type;
        const V fresh = T::shape == field_shape::index ? V(npos) : V{};
        out.assign(static_cast<std::size_t>(m), fresh);
        for (index_t k = 0; k < m; ++k)
          if (const index_t j = src[static_cast<std::size_t>(k)]; j >= 0)
            out[static_cast<std::size_t>(k)] = s[static_cast<std::size_t>(j)];
        if constexpr (T::shape == field_shape::index) {
          for (auto& v : out) {
            if (v == npos) continue;
            const index_t nv = (v >= 0 && v < n_total_) ? rep.old_to_new[static_cast<std::size_t>(v)] : npos;
            if (nv == npos) ++rep.references_lost;
            v = nv;
          }
        }
      }
      s = std::move(out);
    });
    auto& id = get<field::id>();
    auto& roles = get<field::role>();
    auto& parents = get<field::parent>();
    for (index_t k = 0; k < m; ++k) {
      const std::size_t ks = static_cast<std::size_t>(k);
      const index_t s = src[ks];
      if (k < n_real) {
        if (s < 0 || s >= n_real_ || is_born(k)) {  // new, born or promoted: a fresh persistent id
          id[ks] = next_id_++;
          roles[ks] = ghost_role::none;
          parents[ks] = npos;
        }
      } else if (s < 0) {
        id[ks] = no_id;
      }
    }
    n_real_ = n_real;
    n_total_ = m;
    return rep;
  }

  typename tuple_of<fields>::type data_;
  index_t n_real_ = 0;
  index_t n_total_ = 0;
  particle_id next_id_ = 0;
};

}  // namespace mpskit
