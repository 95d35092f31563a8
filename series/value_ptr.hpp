#pragma once
// ValuePtr<T>: a T on the heap with a value's semantics (a copy copies the T, a move moves the pointer), so a class
// can hold a member whose type its header does not define (the pimpl idiom with copies). The class declares its copy,
// move and destructor in its header and defaults them in the one file that defines T.
#include <memory>
#include <utility>

namespace pgi {

template <class T>
class ValuePtr {
public:
    ValuePtr() = default;
    ValuePtr(const ValuePtr& other) : p_(other.p_ ? std::make_unique<T>(*other.p_) : nullptr) {}
    ValuePtr(ValuePtr&&) noexcept = default;
    /// Assigns in place when both hold a T (T's own assignment: no allocation when T's allocates none).
    ValuePtr& operator=(const ValuePtr& other) {
        if (!other.p_)
            p_.reset();
        else if (p_)
            *p_ = *other.p_;
        else
            p_ = std::make_unique<T>(*other.p_);
        return *this;
    }
    ValuePtr& operator=(ValuePtr&&) noexcept = default;
    ~ValuePtr() = default;

    /// Holds a T made of args from now on.
    template <class... Args>
    T& emplace(Args&&... args) {
        p_ = std::make_unique<T>(std::forward<Args>(args)...);
        return *p_;
    }
    explicit operator bool() const { return p_ != nullptr; }
    // const as a value member is: a const holder reads its T, it does not change it
    T& operator*() { return *p_; }
    const T& operator*() const { return *p_; }
    T* operator->() { return p_.get(); }
    const T* operator->() const { return p_.get(); }

private:
    std::unique_ptr<T> p_;
};

}  // namespace pgi
