"""Studies of the seed papers that are not part of the models: the 3-SPS-S's
section 4 ranges (:mod:`.sps_s_paper`) and the 2-CPR/RRR's motion example
(:mod:`.cpr_rrr_motion`).  They use the mechanisms; the mechanisms never use them."""
