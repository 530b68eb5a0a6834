// A half-open range of indices [begin, end) usable in range-for, so that
// compressed (CSR) arrays read as `for (int k : model.memberships(v))`.
#ifndef POLYFIT_UTIL_INDEX_RANGE_H_
#define POLYFIT_UTIL_INDEX_RANGE_H_

namespace polyfit {

class IndexRange {
 public:
  class Iterator {
   public:
    explicit Iterator(int i) : i_(i) {}
    int operator*() const { return i_; }
    Iterator& operator++() {
      ++i_;
      return *this;
    }
    bool operator!=(const Iterator& other) const { return i_ != other.i_; }
    bool operator==(const Iterator& other) const { return i_ == other.i_; }

   private:
    int i_;
  };

  IndexRange(int begin, int end) : begin_(begin), end_(end) {}
  Iterator begin() const { return Iterator(begin_); }
  Iterator end() const { return Iterator(end_); }
  int front() const { return begin_; }
  int size() const { return end_ - begin_; }
  bool empty() const { return end_ == begin_; }

 private:
  int begin_, end_;
};

}  // namespace polyfit

#endif  // POLYFIT_UTIL_INDEX_RANGE_H_
