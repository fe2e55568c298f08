// Counts heap allocations made by the current thread while a counter is
// alive (global operator new is replaced in allocation_counter.cc, linked
// only into the tests that use it).
#ifndef KCRIG_TESTS_SUPPORT_ALLOCATION_COUNTER_H_
#define KCRIG_TESTS_SUPPORT_ALLOCATION_COUNTER_H_

namespace kcrig {

class AllocationCounter {
 public:
  AllocationCounter();
  ~AllocationCounter();
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;

  // Allocations on this thread since construction.
  long count() const;

 private:
  long start_;
};

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_ALLOCATION_COUNTER_H_
