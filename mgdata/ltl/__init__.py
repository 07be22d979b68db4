"""mgdata.ltl"""
