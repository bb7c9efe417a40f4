#include "omicron_test_util.h"
