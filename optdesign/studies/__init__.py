"""Studies of the seed papers that are not part of the models: the 3-SPS-S's
section 4 ranges (:mod:`.sps_s_paper`), the 2-CPR/RRR's motion example
(:mod:`.cpr_rrr_motion`) and what the 3-P(4S)'s design box decides
(:mod:`.p4s_paper`: the text a report prints about Table 3).  They use the mechanisms; the mechanisms never use them."""
