#include "daemon/service/tar_policy.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <string>

namespace dfsm::service {
namespace {

std::string PolicyErrorOf(TarPolicy* policy, const std::string& name, mode_t type,
                          bool hard_link = false) {
  try {
    policy->Admit(name, type, hard_link, 0);
  } catch (const TarError& e) {
    return e.what();
  }
  return "";
}

TEST(TarPolicyTest, NormalizesNamesAndSkipsTheTop) {
  TarPolicy policy({});
  EXPECT_EQ(policy.Admit("./", S_IFDIR, false, 0), "");
  EXPECT_EQ(policy.Admit("./burst/", S_IFDIR, false, 0), "burst");
  EXPECT_EQ(policy.Admit("burst//frames/./0.png", S_IFREG, false, 3), "burst/frames/0.png");
  EXPECT_NE(PolicyErrorOf(&policy, "burst/frames/0.png/", S_IFDIR).find("duplicate"),
            std::string::npos);
}

TEST(TarPolicyTest, RefusesEverythingButFilesAndDirectoriesByName) {
  TarPolicy policy({});
  EXPECT_EQ(PolicyErrorOf(&policy, "dev/sda", S_IFBLK),
            "tar entry 'dev/sda': device files are not allowed");
  EXPECT_NE(PolicyErrorOf(&policy, "tty", S_IFCHR).find("device files"), std::string::npos);
  EXPECT_NE(PolicyErrorOf(&policy, "s", S_IFLNK).find("links are not allowed"), std::string::npos);
  EXPECT_NE(PolicyErrorOf(&policy, "h", 0, true).find("links are not allowed"), std::string::npos);
  EXPECT_NE(PolicyErrorOf(&policy, "p", S_IFIFO).find("not a regular file or directory"),
            std::string::npos);
  EXPECT_NE(PolicyErrorOf(&policy, "o", S_IFSOCK).find("not a regular file or directory"),
            std::string::npos);
  EXPECT_THROW(policy.Finish(), TarError);  // nothing was admitted
}

// A file may not be a directory that holds something, in either order.
TEST(TarPolicyTest, NothingLiesBelowAFile) {
  TarPolicy policy({});
  policy.Admit("a/b/c", S_IFREG, false, 1);
  EXPECT_NE(PolicyErrorOf(&policy, "a/b", S_IFREG).find("'a/b/c' lies below it"),
            std::string::npos);
  EXPECT_EQ(policy.Admit("a/b", S_IFDIR, false, 0), "a/b");
  EXPECT_NE(PolicyErrorOf(&policy, "a/b/c/d", S_IFREG).find("lies below the file 'a/b/c'"),
            std::string::npos);
  EXPECT_NO_THROW(policy.Finish());
}

}  // namespace
}  // namespace dfsm::service
