// For tests: the MakeHuman body of ../shared/data, loaded once per test
// program. Null where the data is absent: the caller skips with a message.
#ifndef POLYFIT_DRAPE_BODY_MAKEHUMAN_TEST_BODY_H_
#define POLYFIT_DRAPE_BODY_MAKEHUMAN_TEST_BODY_H_

#include <filesystem>
#include <memory>

#include "drape/body/makehuman_body.h"

namespace polyfit {

// body_dir: the folder with makehuman/ and mpfb2_rigs/.
inline const SkinnedBody* SharedMakeHumanBody(const std::filesystem::path& body_dir) {
  static const std::unique_ptr<const SkinnedBody> body =
      std::filesystem::exists(body_dir / "makehuman/base.obj")
          ? std::make_unique<const SkinnedBody>(LoadMakeHumanBody(body_dir.string()))
          : nullptr;
  return body.get();
}

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_BODY_MAKEHUMAN_TEST_BODY_H_
