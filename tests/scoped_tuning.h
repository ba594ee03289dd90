// scoped_tuning.h — sets one field of a backend's EngineTuning
// (host/engine/engine_tuning.h) for the lifetime of the object.
#pragma once

#include "host/engine/engine.h"

namespace brdftab::test {

// ScopedTuning on(*device, &EngineTuning::sample_parallel, LaunchChoice::On):
// the launches of `backend` started while `on` lives use that value; the
// destructor puts back the tuning the backend had before.  Nested objects
// undo in reverse order, as scopes end.
class ScopedTuning {
public:
    template <class Field, class Value>
    ScopedTuning(Backend& backend, Field EngineTuning::*field, Value value)
        : backend_(backend), before_(backend.tuning()) {
        EngineTuning changed = before_;
        changed.*field = static_cast<Field>(value);
        backend_.set_tuning(changed);
    }
    ~ScopedTuning() { backend_.set_tuning(before_); }
    ScopedTuning(const ScopedTuning&) = delete;
    ScopedTuning& operator=(const ScopedTuning&) = delete;

private:
    Backend& backend_;
    EngineTuning before_;
};

}  // namespace brdftab::test
