#include <cstdlib>

#include <gtest/gtest.h>

int main(int argc, char** argv) {
    // Defaults only: a variable already set by the caller wins.
    setenv("POCL_MAX_PTHREAD_COUNT", "2", 0);
    setenv("POCL_CACHE_DIR", RAYCLASS_TEST_POCL_CACHE, 0);
    setenv("RAYCLASS_CACHE_DIR", RAYCLASS_TEST_PROGRAM_CACHE, 0);
    setenv("RAYCLASS_SOURCE_DIR", RAYCLASS_TEST_SOURCE_DIR, 0);
    setenv("RAYCLASS_BINARY", RAYCLASS_TEST_BINARY, 0);
    testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}
