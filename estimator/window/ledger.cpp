// The factor ledger: each measurement's fate when it leaves the window.
#include "estimator/window/ledger.hpp"

namespace ovo::estimator {

bool FactorLedger::record(const FactorKey& key, Fate fate) {
  if (!fates_.emplace(key, fate).second) {
    ++refused_;
    return false;
  }
  ++recorded_[{key.kind, fate}];
  return true;
}

int FactorLedger::recorded(FactorKind kind, Fate fate) const {
  const auto it = recorded_.find({kind, fate});
  return it == recorded_.end() ? 0 : it->second;
}

std::optional<FactorLedger::Fate> FactorLedger::fate(const FactorKey& key) const {
  const auto it = fates_.find(key);
  if (it == fates_.end()) return std::nullopt;
  return it->second;
}

void FactorLedger::forgetBefore(int oldest_kf_id) {
  std::erase_if(fates_, [&](const auto& entry) { return entry.first.kf_id < oldest_kf_id; });
}

}  // namespace ovo::estimator
