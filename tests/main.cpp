// The one doctest main of the test suites (STYLE.md "Tests").
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>
