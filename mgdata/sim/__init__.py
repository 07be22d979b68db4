"""mgdata.sim"""
