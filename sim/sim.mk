# sim/: octo-sim, the X-Plane 11/12 stand-in (C++17, Eigen).

SIM_SRC   := $(sort $(wildcard sim/*.cpp))
SIM_OBJ   := $(SIM_SRC:sim/%.cpp=$(B)/sim/%.o)
SIM_INC   := -Isim -isystem $(EIGEN_INC) -isystem $(GEN)/lcm -isystem $(LCM_INC)

$(B)/sim/%.o: sim/%.cpp $(B)/config.mk | $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CXX) $(CXXFLAGS_SIM) $(SIM_INC) -c $< -o $@

$(B)/octo-sim: $(SIM_OBJ)
	$(CXX) $(OPT) -o $@ $(SIM_OBJ) $(LCM_LDFLAGS) -lm

ALL_TARGETS += $(B)/octo-sim
