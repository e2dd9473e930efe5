# sim/: octo-sim, the X-Plane 11/12 stand-in (C++17, Eigen), and its C++ unit
# tests (sim/tests/*.cpp -> build/sim-tests, run by `make test-sim` and by
# tests/py/test_sim_model.py). `make sim-asan` builds both with ASan/UBSan into
# build/sim-asan/ (run pytest with OCTO_BUILD=build/sim-asan to use them).

SIM_SRC   := $(sort $(wildcard sim/*.cpp))
SIM_OBJ   := $(SIM_SRC:sim/%.cpp=$(B)/sim/%.o)
SIM_LIB_OBJ := $(filter-out $(B)/sim/main.o,$(SIM_OBJ))
SIM_INC   := -Isim -isystem $(EIGEN_INC) -isystem $(GEN)/lcm -isystem $(LCM_INC)
SIM_TEST_SRC := $(sort $(wildcard sim/tests/*.cpp))
SIM_TEST_OBJ := $(SIM_TEST_SRC:sim/tests/%.cpp=$(B)/sim-test-obj/%.o)

$(B)/sim/%.o: sim/%.cpp $(B)/config.mk | $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CXX) $(CXXFLAGS_SIM) $(SIM_INC) -c $< -o $@

$(B)/sim-test-obj/%.o: sim/tests/%.cpp $(B)/config.mk | $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CXX) $(CXXFLAGS_SIM) $(SIM_INC) -c $< -o $@

# libocto-plant.a: everything but main(): the plant with its C interface
# (plant.h, used by octo-sil) and the UDP server that octo-sim's main() runs.
$(B)/libocto-plant.a: $(SIM_LIB_OBJ)
	@rm -f $@; $(AR) rcs $@ $^

$(B)/octo-sim: $(B)/sim/main.o $(B)/libocto-plant.a
	$(CXX) $(OPT) -o $@ $(B)/sim/main.o $(B)/libocto-plant.a $(LCM_LDFLAGS) -lm

$(B)/sim-tests: $(SIM_LIB_OBJ) $(SIM_TEST_OBJ)
	$(CXX) $(OPT) -o $@ $(SIM_LIB_OBJ) $(SIM_TEST_OBJ) $(LCM_LDFLAGS) -lm

# sanitizer builds (not part of `make all`)
SIM_ASAN_OBJ := $(SIM_SRC:sim/%.cpp=$(B)/sim-asan/obj/%.o)
SIM_ASAN_TEST_OBJ := $(SIM_TEST_SRC:sim/tests/%.cpp=$(B)/sim-asan/obj/tests/%.o)
$(B)/sim-asan/obj/%.o: sim/%.cpp $(B)/config.mk | $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CXX) $(CXXFLAGS_SIM) $(SAN) $(SIM_INC) -c $< -o $@
$(B)/sim-asan/obj/tests/%.o: sim/tests/%.cpp $(B)/config.mk | $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CXX) $(CXXFLAGS_SIM) $(SAN) $(SIM_INC) -c $< -o $@
$(B)/sim-asan/octo-sim: $(SIM_ASAN_OBJ)
	$(CXX) $(OPT) $(SAN) -o $@ $^ $(LCM_LDFLAGS) -lm
$(B)/sim-asan/sim-tests: $(filter-out $(B)/sim-asan/obj/main.o,$(SIM_ASAN_OBJ)) $(SIM_ASAN_TEST_OBJ)
	$(CXX) $(OPT) $(SAN) -o $@ $^ $(LCM_LDFLAGS) -lm

.PHONY: test-sim sim-asan
test-sim: $(B)/sim-tests
	$(B)/sim-tests
sim-asan: $(B)/sim-asan/octo-sim $(B)/sim-asan/sim-tests

ALL_TARGETS += $(B)/octo-sim $(B)/sim-tests
