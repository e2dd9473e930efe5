# octo-sil: octo-fw's app on the in-process platform (firmware/hal/sil/) linked with
# octo-sim's plant (build/libocto-plant.a). From hal/host it reuses the X-Plane
# client and codec, the parameter file and the LCM log, object for object, and
# hal/hal.c (hal_reportf). Its own sources: sil.c (the loop and the struct hal), cmdline.c
# (the command line) and script.c (--script: the ground station's steps).

SIL_SRC     := $(sort $(wildcard firmware/hal/sil/*.c))
SIL_OBJ     := $(SIL_SRC:firmware/hal/sil/%.c=$(B)/sil/%.o)
SIL_FW_OBJ  := $(filter $(B)/fw/app/%.o,$(FW_OBJ)) $(B)/fw/hal/hal.o \
               $(addprefix $(B)/fw/hal/host/,xp_client.o xp_proto.o lcm_log.o param_file.o udp_addr.o)

$(B)/sil/%.o: firmware/hal/sil/%.c $(B)/config.mk | $(MAVLINK_STAMP) $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) -D_POSIX_C_SOURCE=200809L $(FW_INC) -Ifirmware/hal/host -Isim -c $< -o $@

$(B)/octo-sil: $(SIL_OBJ) $(SIL_FW_OBJ) $(B)/libcore.a $(B)/liblcmtypes.a $(B)/libocto-plant.a
	$(CXX) $(OPT) -o $@ $(SIL_OBJ) $(SIL_FW_OBJ) $(B)/libocto-plant.a $(B)/libcore.a $(B)/liblcmtypes.a \
	  $(LCM_LDFLAGS) -lm

ALL_TARGETS += $(B)/octo-sil

# octo-sil-fixed: the same on the Q16.16 core, from octo-fw-fixed's objects.
SIL_FIXED_OBJ    := $(SIL_SRC:firmware/hal/sil/%.c=$(B)/sil-fixed/%.o)
SIL_FW_FIXED_OBJ := $(SIL_FW_OBJ:$(B)/fw/%=$(B)/fw-fixed/%)

$(B)/sil-fixed/%.o: firmware/hal/sil/%.c $(B)/config.mk | $(MAVLINK_STAMP) $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) -DOCTO_FIXED=1 -D_POSIX_C_SOURCE=200809L $(FW_INC) -Ifirmware/hal/host -Isim -c $< -o $@

$(B)/octo-sil-fixed: $(SIL_FIXED_OBJ) $(SIL_FW_FIXED_OBJ) $(B)/libcore-fixed.a $(B)/liblcmtypes.a $(B)/libocto-plant.a
	$(CXX) $(OPT) -o $@ $(SIL_FIXED_OBJ) $(SIL_FW_FIXED_OBJ) $(B)/libocto-plant.a $(B)/libcore-fixed.a \
	  $(B)/liblcmtypes.a $(LCM_LDFLAGS) -lm

ALL_TARGETS += $(B)/octo-sil-fixed

# octo-sil-asan: the same under AddressSanitizer and UBSan (not part of `all`), from the
# sanitizer objects of octo-fw-asan and sim-asan.
SIL_ASAN_OBJ    := $(SIL_SRC:firmware/hal/sil/%.c=$(B)/sil-asan/%.o)
SIL_FW_ASAN_OBJ := $(SIL_FW_OBJ:$(B)/fw/%=$(B)/fw-asan/%)
SIL_SIM_ASAN_OBJ := $(filter-out $(B)/sim-asan/obj/main.o,$(SIM_ASAN_OBJ))

$(B)/sil-asan/%.o: firmware/hal/sil/%.c $(B)/config.mk | $(MAVLINK_STAMP) $(LCM_STAMP)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS_FW) $(SAN) -D_POSIX_C_SOURCE=200809L $(FW_INC) -Ifirmware/hal/host -Isim -c $< -o $@

$(B)/octo-sil-asan: $(SIL_ASAN_OBJ) $(SIL_FW_ASAN_OBJ) $(SIL_SIM_ASAN_OBJ) $(B)/libcore-asan.a $(B)/liblcmtypes.a
	$(CXX) $(OPT) $(SAN) -o $@ $(SIL_ASAN_OBJ) $(SIL_FW_ASAN_OBJ) $(SIL_SIM_ASAN_OBJ) $(B)/libcore-asan.a \
	  $(B)/liblcmtypes.a $(LCM_LDFLAGS) -lm
