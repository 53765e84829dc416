MODULE PickPlace
    !***********************************************************
    ! Pick and place cell, IRB 120 with a parallel gripper.
    ! Parts come in on the table work object, leave on the tray.
    !***********************************************************
    PERS tooldata tGripper:=[TRUE,[[0,0,115.5],[1,0,0,0]],[0.45,[0,0,50],[1,0,0,0],0,0,0]];
    TASK PERS wobjdata wobjTable:=[FALSE,TRUE,"",[[300,-150,50],[0.9659258,0,0,0.258819]],[[0,0,0],[1,0,0,0]]];
    CONST jointtarget jHome:=[[0,0,0,0,30,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pHome:=[[364.35,0.00,594.00],[0,0.866025,0,0.5],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pApproach:=[[76.57,-9.58,250.38],[-0.011718,0.931016,-0.360296,0.057085],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pPick:=[[85.73,-24.54,157.8],[-0.006062,0.927826,-0.369061,0.053819],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    PERS robtarget pLift:=[[72.85,4.18,314.36],[0.12778,0.833884,-0.535976,0.032232],[-1,-1,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    ! the arc over the fixture
    CONST robtarget pCirc1:=[[236.16,114.71,304.44],[0.143039,-0.426472,0.891477,-0.054141],[0,0,1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pCirc2:=[[253.04,149.36,244.26],[-0.015947,-0.493303,0.852449,-0.172418],[0,-1,1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    VAR robtarget pPlace:=[[395.45,237.99,340.15],[0.68653,0.464647,0.515678,0.216462],[0,0,-2,1],[120.5,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pArr{3}:=[
        [[-17.90,-105.76,294.24],[0.037393,0.778642,-0.59841,0.184996],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]],
        [[-35.65,-123.15,287.10],[0.028115,-0.683998,0.708516,-0.17135],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]],
        [[-54.41,-139.81,280.76],[0.093378,-0.574396,0.798708,-0.153022],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]];
    VAR robtarget pTemp;
    VAR num nPart:=0;

    PROC main()
        MoveAbsJ jHome\NoEOffs, v1000, z50, tool0;
        MoveJ pHome, v1000, z50, tool0;
        WHILE nPart < 3 DO
            Incr nPart;
            PickPart;
            PlacePart;
        ENDWHILE
        MoveAbsJ jHome\NoEOffs, v1000, fine, tool0;
    ENDPROC

    PROC PickPart()
        MoveJ pApproach, v500, z50, tGripper\WObj:=wobjTable;
        MoveL pPick, v100, fine, tGripper\WObj:=wobjTable;
        ! close the gripper, then back out 100 mm (computed when the program runs)
        SetDO doGripper, 1;
        WaitTime 0.3;
        MoveL Offs(pPick,0,0,100), v200, z10, tGripper\WObj:=wobjTable;
        MoveL pLift, v500, z20, tGripper\WObj:=wobjTable;
    ENDPROC

    PROC PlacePart()
        MoveC pCirc1, pCirc2, v300, z10, tGripper\WObj:=wobjTable;
        MoveJ pPlace, v800, z50, tGripper\WObj:=wobjTable;
        MoveL RelTool(pPlace,0,0,-40), v100, fine, tGripper\WObj:=wobjTable;
        SetDO doGripper, 0;
        FOR i FROM 1 TO 3 DO
            MoveL pArr{i}, v400, z10, tGripper\WObj:=wobjTable;
        ENDFOR
        pTemp := CRobT(\Tool:=tGripper\WObj:=wobjTable);
        MoveL pTemp, v100, fine, tGripper\WObj:=wobjTable;
        ! a point typed in by hand at commissioning
        MoveL [[247.26,255.07,433.31],[0.259003,-0.389596,0.880416,-0.077463],[0,-1,2,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]], v200, z20, tool0;
    ENDPROC
ENDMODULE
