lib.o: \
 /tmp/pytest-of-root/pytest-42/test_the_second_identical_comp0/runtime/lib.cpp \
 /tmp/pytest-of-root/pytest-42/test_the_second_identical_comp0/runtime/lib.h
